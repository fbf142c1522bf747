//! placeholder
use crate::error::MeshError;
use crate::mesh::Mesh;
use std::io::Write;
use std::path::Path;

type Parsed = (Vec<[f64; 3]>, Vec<[u32; 3]>);

pub(super) fn parse(_bytes: &[u8], path: &Path) -> Result<Parsed, MeshError> {
    Err(super::perr(path, 0, "stl reading is not implemented yet"))
}
pub(super) fn write(_w: &mut dyn Write, _mesh: &Mesh) -> std::io::Result<()> {
    Err(std::io::Error::other("STL writing is not implemented yet"))
}
