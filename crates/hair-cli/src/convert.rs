//! `hair convert IN OUT`: convert strands between `.tfx` and `.hair`.

use anyhow::{Result, bail};
use std::path::PathBuf;

/// Arguments of `hair convert`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Input file (.tfx or .hair).
    pub input: PathBuf,
    /// Output file (.tfx or .hair). An existing file is kept unless `--force` is given.
    pub output: PathBuf,
    /// Replace the output file if it exists (never the input).
    #[arg(long)]
    pub force: bool,
}

/// Runs the command.
pub fn run(args: Args) -> Result<()> {
    // Written over itself, a file would lose what the other format cannot hold (a `.hair`
    // file's header text, say): never, even with `--force`.
    if let (Ok(a), Ok(b)) = (args.input.canonicalize(), args.output.canonicalize())
        && a == b
    {
        bail!(
            "{}: the output is the input file; write the conversion to another file",
            args.output.display()
        );
    }
    let strands = hair::io::read_strands(&args.input)?;
    if !args.force && args.output.exists() {
        bail!(
            "{}: exists; pass --force to replace it",
            args.output.display()
        );
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A conversion never writes over its input, and over an existing output only when asked.
    #[test]
    fn existing_files_are_kept_unless_forced() {
        let dir = std::env::temp_dir().join(format!("hair-convert-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let strands =
            hair::io::Strands::from_polylines(vec![vec![[0.0; 3], [0.0, -1.0, 0.0]]; 2]).unwrap();
        let input = dir.join("in.hair");
        hair::io::write_strands(&input, &strands).unwrap();
        let original = std::fs::read(&input).unwrap();
        let to = |output: PathBuf, force: bool| Args {
            input: input.clone(),
            output,
            force,
        };
        let args = |output: &str, force: bool| to(dir.join(output), force);
        for force in [false, true] {
            // The input by its own path, and by another.
            for output in [dir.join("in.hair"), dir.join(".").join("in.hair")] {
                let err = run(to(output, force)).unwrap_err().to_string();
                assert!(err.contains("the output is the input"), "{err}");
            }
        }
        assert_eq!(std::fs::read(&input).unwrap(), original);
        run(args("out.tfx", false)).unwrap();
        std::fs::write(dir.join("out.tfx"), b"mine").unwrap();
        let err = run(args("out.tfx", false)).unwrap_err().to_string();
        assert!(err.contains("--force"), "{err}");
        assert_eq!(std::fs::read(dir.join("out.tfx")).unwrap(), b"mine");
        run(args("out.tfx", true)).unwrap();
        let back = hair::io::read_strands(&dir.join("out.tfx")).unwrap();
        assert_eq!(back.points, strands.points);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
