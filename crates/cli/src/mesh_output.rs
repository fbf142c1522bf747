//! Writing a command's result mesh with the attributes of the file it came
//! from (issue 38): texture coordinates, materials, groups, colours, extra
//! PLY properties, STL attribute bytes and the file's polygons come back
//! around the new positions (`normalnet_mesh::io::write_mesh_file`), or the
//! triangles with `--triangulate`. A result whose vertices or faces no
//! longer match the file (`--remove-outliers`) is written without them,
//! and stderr says so; so are the writer's own warnings (another format
//! than the input's).

use anyhow::Context;
use normalnet_mesh::Mesh;
use normalnet_mesh::io::{
    Attributes, FileWriteOptions, Format, WriteOptions, write_mesh_as, write_mesh_file_as,
};
use std::path::Path;

/// Writes `result` to `path` in `format` with `attributes` (read from
/// `input`), printing on stderr what could not be kept.
///
/// # Errors
/// Writing fails (folder, permissions, a coordinate STL cannot hold).
pub fn write_result(
    path: &Path,
    format: Format,
    result: &Mesh,
    attributes: &Attributes,
    input: &Path,
    options: &FileWriteOptions,
) -> anyhow::Result<()> {
    let warnings = if let Err(e) = attributes.check_matches(result) {
        write_mesh_as(
            path,
            result,
            format,
            &WriteOptions {
                ply_ascii: options.ply_ascii,
            },
        )
        .with_context(|| format!("writing {}", path.display()))?;
        vec![format!(
            "{}: written without the attributes of {} ({e}): positions and triangles only",
            path.display(),
            input.display()
        )]
    } else {
        write_mesh_file_as(path, result, attributes, format, options)
            .with_context(|| format!("writing {}", path.display()))?
    };
    for warning in warnings {
        stderr_line!("warning: {warning}");
    }
    Ok(())
}
