//! The `hair` command: simulate, measure and chart.
//!
//! Every subcommand is a module with its own clap `Args` and a `run` function; `main` only
//! dispatches. Charts (plotters) live here, never in the libraries.

mod accuracy;
mod bench;
mod chart;
mod convert;
mod export;
mod hierarchy;
mod render_check;
mod run;
mod scenes;
mod soak;
mod stability;
mod strand_setup;
mod study;
mod view;
mod xpbd_peer;

use clap::{Parser, Subcommand};
use hair_grid::Kernel;

/// Interactive, physically based hair: simulation, collision, level of detail.
#[derive(Debug, Parser)]
#[command(name = "hair", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Simulate a scene: per-frame metrics and a summary.
    Run(run::Args),
    /// List the built-in scenes.
    Scenes(scenes::Args),
    /// Convert strands between .tfx and .hair.
    Convert(convert::Args),
    /// Stability map of every integrator over stiffness x time step.
    Stability(stability::Args),
    /// Accuracy against cost of every integrator, and the elastica statics.
    Accuracy(accuracy::Args),
    /// Throughput benchmarks, each measured beside a peer in the same run.
    Bench(bench::Args),
    /// Build the strip / cluster / strand-group hierarchy and report its size.
    Hierarchy(hierarchy::Args),
    /// Render the procedural head on the GPU and the CPU reference and compare.
    RenderCheck(render_check::Args),
    /// Every LOD policy and collision method on a scene: cost and error against the finest.
    Study(study::Args),
    /// The interactive salon window: tools on the hair, recorded and replayable.
    View(view::Args),
    /// Soak test: random salon tool events of every kind while the scene runs; checks finite
    /// state, body penetration, energy and allocations after a warm-up.
    Soak(soak::Args),
}

/// The grid kernel `HAIR_GRID_KERNEL` asks for (`avx512`, `avx2`, `baseline` or `auto`; unset:
/// `auto`, the widest this processor has), or the value when it names no kernel. `hair bench
/// grid` and `hair run` run it, so that one machine measures every kernel (every kernel gives
/// the same pairs, so results do not depend on
/// it).
fn grid_kernel_from_env() -> Result<Kernel, String> {
    match std::env::var("HAIR_GRID_KERNEL") {
        Err(std::env::VarError::NotPresent) => Ok(Kernel::Auto),
        Err(std::env::VarError::NotUnicode(v)) => Err(v.to_string_lossy().into_owned()),
        Ok(v) => Kernel::from_name(v.trim()).map_err(|_| v),
    }
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    // A misspelt kernel would otherwise run the widest one unnoticed, and its figures would be
    // taken for the narrower kernel's: every command refuses it before any work.
    let grid_kernel = match grid_kernel_from_env() {
        Ok(kernel) => kernel,
        Err(value) => {
            eprintln!(
                "error: HAIR_GRID_KERNEL={value:?} names no kernel (avx512, avx2, baseline or \
                 auto; unset: the widest this processor has)"
            );
            return std::process::ExitCode::FAILURE;
        }
    };
    let result = match cli.command {
        Command::Run(args) => run::run(run::Args {
            grid_kernel,
            ..args
        }),
        Command::Scenes(args) => scenes::run(args),
        Command::Convert(args) => convert::run(args),
        Command::Stability(args) => stability::run(args),
        Command::Accuracy(args) => accuracy::run(args),
        Command::Bench(args) => bench::run(args, grid_kernel),
        Command::Hierarchy(args) => hierarchy::run(args),
        Command::RenderCheck(args) => render_check::run(args),
        Command::Study(args) => study::run(args),
        Command::View(args) => view::run(args),
        Command::Soak(args) => soak::run(args),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {}", one_line(&err));
            std::process::ExitCode::FAILURE
        }
    }
}

/// The error and its causes on one line, leaving out a cause whose text the line already holds
/// (the library's errors often include their source in their own message).
fn one_line(err: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in err.chain() {
        let text = cause.to_string();
        if !line.contains(&text) {
            if !line.is_empty() {
                line.push_str(": ");
            }
            line.push_str(&text);
        }
    }
    line
}

#[cfg(test)]
mod tests {
    use super::one_line;

    #[test]
    fn a_cause_already_in_the_message_is_printed_once() {
        let dynamics =
            hair::HairError::Dynamics(hair::dynamics::DynamicsError::NonFiniteParameter {
                name: "dt",
                value: f64::NAN,
            });
        let text = dynamics.to_string();
        let line = one_line(&anyhow::Error::new(dynamics).context("scene.ron"));
        assert_eq!(line, format!("scene.ron: {text}"));
        assert_eq!(line.matches("dt").count(), 1, "{line}");
    }
}
