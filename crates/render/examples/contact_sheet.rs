//! Puts PNG files side by side: `contact_sheet OUT.png COLS IN.png...`
//! (each labelled with its file name). A small tool for looking at many renders at once.

use normalnet_render::{Image, compose_grid};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 3 {
        return Err("usage: contact_sheet OUT.png COLS IN.png...".into());
    }
    let cols: usize = args[1].parse()?;
    let mut images = Vec::new();
    let mut labels = Vec::new();
    for path in &args[2..] {
        images.push(Image::decode_png(&std::fs::read(path)?)?);
        labels.push(
            std::path::Path::new(path)
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default(),
        );
    }
    compose_grid(&images, cols, &labels).write_png(&args[0])?;
    Ok(())
}
