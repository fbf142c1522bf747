//! Voxelization of face neighbourhoods (SPEC §5), procedural shapes and training samples (SPEC §8).
