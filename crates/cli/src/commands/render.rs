//! `normalnet render`: a mesh to PNG with the software rasterizer of
//! `normalnet-render`; with `--gt`, faces are coloured by their angular error
//! against the ground truth (turbo colormap, colour bar with ticks, E_a in
//! the title). An OBJ whose materials have texture maps (`mtllib`, `usemtl`,
//! `map_Kd` PNG) or colours (`Kd`) is drawn with them unless `--gt` or
//! `--no-texture` is given (issue 38).

use anyhow::Context;
use normalnet_mesh::{Format, Mesh};
use normalnet_render::{
    Projection, RenderOptions, Shading, Texture, obj_texture, render_against_gt,
};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `normalnet render`.
#[derive(clap::Args)]
pub struct Args {
    /// Mesh to draw (OBJ, OFF, PLY, STL).
    pub mesh: PathBuf,
    /// Ground truth with the same faces: colour faces by angular error against it.
    #[arg(long)]
    pub gt: Option<PathBuf>,
    /// Output PNG (the only format written; other extensions are refused).
    #[arg(long, short)]
    pub out: PathBuf,
    /// Camera direction as AZIMUTH,ELEVATION in degrees (azimuth about +y, 0 = from +z).
    #[arg(long, default_value = "30,20", value_parser = parse_view, allow_hyphen_values = true)]
    pub view: (f64, f64),
    /// Image size WIDTHxHEIGHT in pixels.
    #[arg(long, default_value = "1024x768", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Shading: flat (face normals; shows noise honestly) or smooth (Phong).
    #[arg(long, default_value = "flat", value_parser = ["flat", "smooth"])]
    pub shading: String,
    /// Perspective camera with this field of view in degrees (default: orthographic).
    #[arg(long)]
    pub perspective: Option<f64>,
    /// Top of the error colour scale in degrees (default: the 95th percentile
    /// rounded up to 1, 2, 5, 10, 15, 20, 30, 45, 60 or 90).
    #[arg(long)]
    pub max_error: Option<f64>,
    /// Anti-aliasing: render at N× the size and average down (1–4).
    #[arg(long, default_value_t = 2)]
    pub supersample: u32,
    /// Title drawn at the top-left (default: the file name, plus E_a with --gt).
    #[arg(long)]
    pub title: Option<String>,
    /// Draw an OBJ's faces in the base colour, not with its materials'
    /// textures and colours (these are drawn by default; `--gt` colours by
    /// error instead).
    #[arg(long)]
    pub no_texture: bool,
}

/// Parses `AZ,EL` (degrees).
pub fn parse_view(s: &str) -> Result<(f64, f64), String> {
    let (a, e) = s
        .split_once(',')
        .ok_or_else(|| format!("expected AZIMUTH,ELEVATION in degrees, got {s:?}"))?;
    let az: f64 = a.trim().parse().map_err(|_| format!("bad azimuth {a:?}"))?;
    let el: f64 = e
        .trim()
        .parse()
        .map_err(|_| format!("bad elevation {e:?}"))?;
    if !az.is_finite() || !(-90.0..=90.0).contains(&el) {
        return Err(format!(
            "azimuth must be finite and elevation within -90..=90, got {s:?}"
        ));
    }
    Ok((az, el))
}

/// Parses `WxH` (pixels).
pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("expected WIDTHxHEIGHT, got {s:?}"))?;
    let w: u32 = w.trim().parse().map_err(|_| format!("bad width {w:?}"))?;
    let h: u32 = h.trim().parse().map_err(|_| format!("bad height {h:?}"))?;
    if !(16..=16384).contains(&w) || !(16..=16384).contains(&h) {
        return Err(format!(
            "size must be within 16..=16384 each way, got {s:?}"
        ));
    }
    Ok((w, h))
}

/// Runs `normalnet render`.
pub fn run(args: Args, quiet: bool) -> anyhow::Result<()> {
    let start = Instant::now();
    crate::output::check_file(&args.out, crate::output::PNG, "picture")?;
    let (mesh, texture) = if args.gt.is_none() && !args.no_texture {
        read_with_texture(&args.mesh)?
    } else {
        (crate::input::read_mesh(&args.mesh)?, None)
    };
    let mut options = RenderOptions {
        width: args.size.0,
        height: args.size.1,
        azimuth_deg: args.view.0,
        elevation_deg: args.view.1,
        shading: if args.shading == "smooth" {
            Shading::Smooth
        } else {
            Shading::Flat
        },
        supersample: args.supersample,
        texture,
        ..Default::default()
    };
    if let Some(fov_deg) = args.perspective {
        options.projection = Projection::Perspective { fov_deg };
    }
    let name = args
        .mesh
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let gt = match &args.gt {
        Some(path) => Some(crate::input::read_mesh(path)?),
        None => None,
    };
    let title = args.title.clone().unwrap_or(name);
    let image = render_against_gt(&mesh, gt.as_ref(), &options, &title, args.max_error)
        .with_context(|| match &args.gt {
            Some(g) => format!("comparing {} with {}", args.mesh.display(), g.display()),
            None => format!("rendering {}", args.mesh.display()),
        })?;
    image
        .write_png(&args.out)
        .with_context(|| format!("writing {}", args.out.display()))?;
    if !quiet {
        stderr_line!(
            "wrote {} ({}x{}, {} faces) in {:.2} s",
            args.out.display(),
            image.width(),
            image.height(),
            mesh.num_faces(),
            start.elapsed().as_secs_f64()
        );
    }
    Ok(())
}

/// The mesh of `path` and, for an OBJ with materials, what its faces show;
/// a material library or texture that cannot be read is a warning (the
/// mesh is drawn in the base colour), not an error.
fn read_with_texture(path: &Path) -> anyhow::Result<(Mesh, Option<Texture>)> {
    if Format::from_path(path) != Some(Format::Obj) {
        return Ok((crate::input::read_mesh(path)?, None));
    }
    let file = crate::input::read_mesh_file(path)?;
    let texture = match obj_texture(&file.attributes) {
        Ok(texture) => texture
            .filter(Texture::is_visible)
            .filter(|t| t.faces.len() == file.mesh.num_faces()),
        Err(e) => {
            stderr_line!("warning: {e}; drawing {} without it", path.display());
            None
        }
    };
    Ok((file.mesh, texture))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn view_and_size_parse_and_reject_bad_input() {
        assert_eq!(parse_view("30,-20"), Ok((30.0, -20.0)));
        assert!(parse_view("30").is_err());
        assert!(parse_view("30,100").is_err());
        assert_eq!(parse_size("1024x768"), Ok((1024, 768)));
        assert!(parse_size("1024").is_err());
        assert!(parse_size("0x10").is_err());
    }
}
