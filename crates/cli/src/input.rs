//! Reading the meshes a command is given (issue 14): every command reads
//! through [`read_mesh`] / [`read_mesh_as`], which warn on stderr about
//! outlier vertices (`normalnet_mesh::outliers`: far outside the mesh's
//! robust extent, or isolated spikes). Reading is otherwise unchanged. The
//! commands that write the mesh they read back (`denoise`, `batch`,
//! `noise`) read through [`read_mesh_file`] / [`read_mesh_file_as`] instead,
//! which keep what the file carries beyond positions and triangles (issue
//! 38) and also print what the reader dropped.

use normalnet_mesh::io::{MeshFile, read_mesh_file_as as read_file_as};
use normalnet_mesh::outliers::{OutlierParams, outlier_vertices};
use normalnet_mesh::{Format, Mesh, MeshError};
use std::path::Path;

/// `normalnet_mesh::read_mesh_file`: the mesh and its attributes; prints
/// the reader's warnings and [`warn_outliers`] on stderr.
///
/// # Errors
/// [`MeshError::UnknownFormat`] for an unknown extension, else as
/// `normalnet_mesh::read_mesh_file`.
pub fn read_mesh_file(path: impl AsRef<Path>) -> Result<MeshFile, MeshError> {
    let path = path.as_ref();
    let format = Format::from_path(path).ok_or_else(|| MeshError::UnknownFormat {
        path: path.to_path_buf(),
    })?;
    read_mesh_file_as(path, format)
}

/// `normalnet_mesh::read_mesh_file_as`, with the warnings of [`read_mesh_file`].
pub fn read_mesh_file_as(path: impl AsRef<Path>, format: Format) -> Result<MeshFile, MeshError> {
    let path = path.as_ref();
    let file = read_file_as(path, format)?;
    for warning in &file.warnings {
        stderr_line!("warning: {warning}");
    }
    warn_outliers(path, &file.mesh);
    Ok(file)
}

/// `normalnet_mesh::read_mesh`, then [`warn_outliers`].
pub fn read_mesh(path: impl AsRef<Path>) -> Result<Mesh, MeshError> {
    let path = path.as_ref();
    let mesh = normalnet_mesh::read_mesh(path)?;
    warn_outliers(path, &mesh);
    Ok(mesh)
}

/// `normalnet_mesh::read_mesh_as`, then [`warn_outliers`].
pub fn read_mesh_as(path: impl AsRef<Path>, format: Format) -> Result<Mesh, MeshError> {
    let path = path.as_ref();
    let mesh = normalnet_mesh::read_mesh_as(path, format)?;
    warn_outliers(path, &mesh);
    Ok(mesh)
}

/// The warning line for the outliers of `mesh` read from `path`, `None`
/// when there is none.
pub fn outlier_warning(path: &Path, mesh: &Mesh) -> Option<String> {
    let outliers = outlier_vertices(mesh, &OutlierParams::default());
    let text = outliers.describe(&mesh.positions)?;
    Some(format!(
        "warning: {}: {text}; the classical methods keep them and their faces in place, \
         `normalnet denoise --remove-outliers` drops them",
        path.display()
    ))
}

/// Prints [`outlier_warning`] on stderr (always, also with `--quiet`: it is
/// about the data, not progress).
pub fn warn_outliers(path: &Path, mesh: &Mesh) {
    if let Some(line) = outlier_warning(path, mesh) {
        stderr_line!("{line}");
    }
}
