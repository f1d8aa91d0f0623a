//! `hair scenes`: the built-in scenes.

/// Arguments of `hair scenes`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Print the named scene's RON text instead of the list.
    pub show: Option<String>,
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    match args.show {
        Some(name) => {
            let (_, text) = hair::scene::BUILTIN
                .iter()
                .find(|(n, _)| *n == name)
                .ok_or_else(|| anyhow::anyhow!("no built-in scene `{name}`"))?;
            print!("{text}");
        }
        None => {
            for (name, text) in hair::scene::BUILTIN {
                let about = text
                    .lines()
                    .next()
                    .unwrap_or("")
                    .trim_start_matches("//")
                    .trim();
                println!("{name:10} {about}");
            }
        }
    }
    Ok(())
}
