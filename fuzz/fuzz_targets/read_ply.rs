#![no_main]
//! libFuzzer target: the ply reader (see src/lib.rs for the property).

use libfuzzer_sys::fuzz_target;
use normalnet_mesh::io::Format;

fuzz_target!(|data: &[u8]| normalnet_fuzz::check_reader(data, Format::Ply));
