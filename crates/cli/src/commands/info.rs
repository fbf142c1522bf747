//! `normalnet info`: counts, bounding box, `l_e`, `d_s` and defects of a mesh
//! (SPEC §1; the validation policy of `normalnet_mesh::validate`): boundary
//! and non-manifold edges, non-manifold (bow-tie) vertices, edges traversed
//! twice in the same direction (inconsistent orientation), degenerate and
//! duplicate faces, unreferenced vertices; and the folded faces
//! (`normalnet_filters::self_folded_faces`, the fold check of the mesh
//! against itself: a sign of noise with a tangential part; degenerate faces
//! count as folded too).

use crate::input::read_mesh_as;
use anyhow::Context;
use normalnet_filters::self_folded_faces;
use normalnet_mesh::Topology;
use normalnet_mesh::io::Format;
use normalnet_mesh::validate::validate;
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `normalnet info`.
#[derive(clap::Args)]
pub struct Args {
    /// Mesh file (.obj, .off, .ply, .stl, .gltf, .glb).
    pub mesh: PathBuf,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Read as this format whatever the extension (obj, off, ply, stl, gltf, glb).
    #[arg(long, value_parser = parse_format)]
    pub format: Option<Format>,
}

/// Parses a `--format` value.
pub fn parse_format(s: &str) -> Result<Format, String> {
    Format::from_name(s)
        .ok_or_else(|| format!("unknown format {s:?} (expected obj, off, ply or stl)"))
}

/// The format to read `path` as: `--format`, else the extension.
pub fn format_for(path: &std::path::Path, over: Option<Format>) -> anyhow::Result<Format> {
    match over.or_else(|| Format::from_path(path)) {
        Some(f) => Ok(f),
        None => anyhow::bail!(
            "{}: unknown mesh format (expected .obj, .off, .ply, .stl, .gltf or .glb, or pass --format)",
            path.display()
        ),
    }
}

/// Runs `normalnet info`.
pub fn run(args: Args, _quiet: bool) -> anyhow::Result<()> {
    let t = Instant::now();
    let mesh = read_mesh_as(&args.mesh, format_for(&args.mesh, args.format)?)
        .with_context(|| format!("reading {}", args.mesh.display()))?;
    let load = t.elapsed().as_secs_f64();
    let r = validate(&mesh);
    let topology = Topology::new(mesh.num_vertices(), &mesh.faces);
    let folded_faces = self_folded_faces(&mesh, &topology);
    let folded = folded_faces as f64 / mesh.num_faces().max(1) as f64;
    let mut out = std::io::stdout().lock();
    if args.json {
        let v = serde_json::json!({
            "path": args.mesh,
            "report": r,
            "warnings": r.warnings(),
            "folded_faces": folded_faces,
            "folded_share": folded,
            "load_seconds": load,
            "seconds": t.elapsed().as_secs_f64(),
        });
        writeln!(out, "{}", serde_json::to_string_pretty(&v)?)?;
        return Ok(());
    }
    let [x0, y0, z0] = r.bbox_min;
    let [x1, y1, z1] = r.bbox_max;
    writeln!(out, "{}", args.mesh.display())?;
    writeln!(out, "  vertices               {}", r.vertices)?;
    writeln!(out, "  faces                  {}", r.faces)?;
    writeln!(out, "  edges                  {}", r.edges)?;
    writeln!(
        out,
        "  bounding box           [{x0}, {y0}, {z0}] .. [{x1}, {y1}, {z1}]"
    )?;
    writeln!(out, "  bbox diagonal          {:.6}", r.bbox_diagonal)?;
    writeln!(out, "  mean edge length l_e   {:.6}", r.mean_edge_length)?;
    writeln!(
        out,
        "  mean centre dist d_s   {:.6}",
        r.mean_centre_distance
    )?;
    writeln!(out, "  surface area           {:.6}", r.area)?;
    writeln!(out, "  components             {}", r.components)?;
    writeln!(out, "  Euler characteristic   {}", r.euler_characteristic)?;
    writeln!(out, "  boundary edges         {}", r.boundary_edges)?;
    writeln!(out, "  non-manifold edges     {}", r.non_manifold_edges)?;
    writeln!(out, "  non-manifold vertices  {}", r.non_manifold_vertices)?;
    writeln!(out, "  misoriented edges      {}", r.misoriented_edges)?;
    writeln!(out, "  degenerate faces       {}", r.degenerate_faces)?;
    writeln!(out, "  duplicate faces        {}", r.duplicate_faces)?;
    writeln!(out, "  unreferenced vertices  {}", r.unreferenced_vertices)?;
    writeln!(out, "  outlier vertices       {}", r.outlier_vertices)?;
    writeln!(
        out,
        "  folded faces           {folded_faces} ({:.2} %)",
        100.0 * folded
    )?;
    writeln!(out, "  read in                {:.3} s", load)?;
    for w in r.warnings() {
        writeln!(out, "warning: {w}")?;
    }
    Ok(())
}
