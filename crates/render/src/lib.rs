//! Headless software rasterizer: meshes to PNG, optionally coloured by per-face angular error.
