#![no_main]
//! libFuzzer target: the glTF / GLB reader (`parse_mesh`; GLB or JSON told
//! by the content; see src/lib.rs, `check_reader`, for the property).

use libfuzzer_sys::fuzz_target;
use normalnet_mesh::io::Format;

fuzz_target!(|data: &[u8]| normalnet_fuzz::check_reader(data, Format::Glb));
