//! Triangle meshes for NormalNet: the `Mesh` (positions + faces), its
//! `Topology` (flat CSR connectivity, r-rings), per-face geometry, file I/O
//! (OBJ, OFF, PLY, STL, glTF/GLB; with `read_mesh_file` / `write_mesh_file`, also
//! what a file carries beyond positions and triangles), the noise models of the literature and the error
//! metrics E_a / E_v (SPEC §1–3).
//!
//! Everything downstream (filters, voxelizer, network, CLI) starts here; this
//! crate knows nothing about denoising or deep learning.

pub mod bvh;
pub mod csr;
pub mod error;
pub mod geometry;
pub mod io;
pub mod mesh;
pub mod metrics;
pub mod noise;
pub mod outliers;
pub mod progress;
pub mod scale;
pub mod topology;
pub mod validate;
pub mod vec3;

pub use csr::Csr;
pub use error::MeshError;
pub use geometry::FaceGeometry;
pub use io::{
    Attributes, FileWriteOptions, Format, MeshFile, WriteOptions, read_mesh, read_mesh_as,
    read_mesh_file, write_mesh, write_mesh_as, write_mesh_file,
};
pub use mesh::Mesh;
pub use metrics::{Metrics, compare, per_face_angle_errors};
pub use noise::{NoiseDirection, NoiseParams, add_noise};
pub use outliers::{OutlierParams, Outliers, outlier_vertices};
pub use progress::{NoProgress, Progress};
pub use topology::{NO_FACE, Topology};
pub use validate::{MeshReport, validate};
