//! One module per subcommand; each has `Args` (clap) and `run(args, quiet)`.

pub mod batch;
pub mod bench;
pub mod compare;
pub mod dataset;
pub mod denoise;
pub mod info;
pub mod metrics;
pub mod models;
pub mod noise;
pub mod render;
pub mod shapes;
pub mod train;
pub mod voxelize;
