#![no_main]
//! libFuzzer target: the glTF / GLB reader that keeps the document
//! (`parse_mesh_file`; see src/lib.rs, `check_file_reader` and
//! `check_gltf_corner_values`, for the properties).

use libfuzzer_sys::fuzz_target;
use normalnet_mesh::io::Format;

fuzz_target!(|data: &[u8]| {
    normalnet_fuzz::check_file_reader(data, Format::Glb);
    normalnet_fuzz::check_gltf_corner_values(data);
});
