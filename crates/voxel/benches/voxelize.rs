//! Benchmarks of the voxelizer (filled in below).
fn main() {}
