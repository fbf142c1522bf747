//! `normalnet voxelize`: the voxel grid the network sees for one face
//! (SPEC §5), as a `.npy` array `[3, D, H, W]` (f32; D = local x, H = local
//! y = mean-normal direction, W = local z) or a PNG picture (three
//! orthographic views of the occupied cubes coloured by normal).

use crate::input::read_mesh;
use anyhow::{Context, bail};
use normalnet_mesh::Topology;
use normalnet_voxel::inspect::{grid_picture, write_npy, write_png};
use normalnet_voxel::{Scratch, VoxelParams, Voxelizer};
use std::path::PathBuf;

/// Arguments of `normalnet voxelize`.
#[derive(clap::Args)]
pub struct Args {
    /// Input mesh (OBJ, OFF, PLY, STL).
    pub mesh: PathBuf,
    /// Face index (0-based).
    #[arg(long)]
    pub face: usize,
    /// Grid preset: paper (41³), lite (21³) or tiny (15³).
    #[arg(long, default_value = "lite")]
    pub preset: String,
    /// Yaw about the local y axis in degrees (training augmentation).
    #[arg(long, default_value_t = 0.0)]
    pub yaw: f64,
    /// Output file: `.npy` (raw f32 `[3, D, H, W]`) or `.png` (picture).
    #[arg(long)]
    pub out: PathBuf,
    /// Pixels per cube in the PNG.
    #[arg(long, default_value_t = 8)]
    pub zoom: usize,
}

/// Runs `normalnet voxelize`.
pub fn run(args: Args, quiet: bool) -> anyhow::Result<()> {
    let params = VoxelParams::from_name(&args.preset)?;
    crate::output::check_file(&args.out, &["npy", "png"], "voxel grid")?;
    let ext = args
        .out
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let mesh = read_mesh(&args.mesh)?;
    if args.face >= mesh.num_faces() {
        bail!(
            "{}: face {} out of range (the mesh has {} faces)",
            args.mesh.display(),
            args.face,
            mesh.num_faces()
        );
    }
    if !args.yaw.is_finite() {
        bail!("--yaw must be finite");
    }
    let topology = Topology::new(mesh.num_vertices(), &mesh.faces);
    let voxelizer = Voxelizer::new(&mesh, &topology, params)
        .with_context(|| args.mesh.display().to_string())?;
    let mut grid = vec![0.0f32; params.grid_len()];
    let mut scratch = Scratch::new();
    let frame =
        voxelizer.voxelize_face_with(&mut scratch, args.face, args.yaw.to_radians(), &mut grid);
    let side = params.side();
    if ext.as_deref() == Some("npy") {
        write_npy(&args.out, &[3, side, side, side], &grid)?;
    } else {
        let (w, h, rgb) = grid_picture(&grid, params, args.zoom.clamp(1, 64));
        write_png(&args.out, w, h, &rgb)?;
    }
    if !quiet {
        let n = voxelizer.mean_normals()[args.face];
        stderr_line!(
            "face {} of {}: {} cubes of {} occupied by {} faces; L_c = d_s/α_c = {:.4e}; mean normal ({:.4}, {:.4}, {:.4}); centre ({:.4}, {:.4}, {:.4}); wrote {}",
            args.face,
            args.mesh.display(),
            scratch.last_occupied(),
            params.num_cells(),
            scratch.last_candidates(),
            voxelizer.cube_side(),
            n[0],
            n[1],
            n[2],
            frame.centre[0],
            frame.centre[1],
            frame.centre[2],
            args.out.display()
        );
    }
    Ok(())
}
