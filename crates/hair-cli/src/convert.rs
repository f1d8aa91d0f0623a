//! `hair convert IN OUT`: convert strands between `.tfx` and `.hair`.

use anyhow::Result;
use std::path::PathBuf;

/// Arguments of `hair convert`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Input file (.tfx or .hair).
    pub input: PathBuf,
    /// Output file (.tfx or .hair).
    pub output: PathBuf,
}

/// Runs the command.
pub fn run(args: Args) -> Result<()> {
    let strands = hair::io::read_strands(&args.input)?;
    hair::io::write_strands(&args.output, &strands)?;
    println!(
        "{}: {} strands, {} points -> {}",
        args.input.display(),
        strands.strand_count(),
        strands.points.len(),
        args.output.display()
    );
    Ok(())
}
