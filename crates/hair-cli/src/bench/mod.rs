//! `hair bench SUITE`: throughput of our layers beside a peer measured in the same run.

mod dynamics;
mod grid;
mod render;
mod ssv;

/// Arguments of `hair bench`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    suite: Suite,
}

#[derive(Debug, clap::Subcommand)]
enum Suite {
    /// Node-steps per second of every integrator, 1 thread and all threads.
    Dynamics(dynamics::Args),
    /// Swept-sphere-volume kernels, mesh contacts and cylinder maps against parry3d.
    Ssv(ssv::Args),
    /// Localization-grid build and pair search against a parry3d BVH.
    Grid(grid::Args),
    /// Hair rendering with 16 opacity shadow maps against the unshadowed frame.
    Render(render::Args),
}

/// Runs the chosen suite; the grid suite with `grid_kernel`.
pub fn run(args: Args, grid_kernel: hair_grid::Kernel) -> anyhow::Result<()> {
    match args.suite {
        Suite::Dynamics(a) => dynamics::run(a),
        Suite::Ssv(a) => ssv::run(a),
        Suite::Grid(a) => grid::run(a, grid_kernel),
        Suite::Render(a) => render::run(a),
    }
}
