//! `seacover record`: what a recording holds (`info`) and one channel of it
//! as CSV or JSON lines (`export`).

use std::io::Write;
use std::path::PathBuf;

use seacover::recorder::{inspect, reader::Recording};

#[derive(clap::Subcommand)]
pub(crate) enum Command {
    /// Duration, vessels, channels with message counts, H at start and end,
    /// gaps in the data.
    Info {
        /// An MCAP recording (of `serve`, `demo --record` or `sim --record`);
        /// one cut short is read as far as it goes.
        #[arg(value_name = "FILE")]
        file: PathBuf,
        /// As JSON.
        #[arg(long)]
        json: bool,
    },
    /// One channel's messages as CSV (coverage: H and each vessel's E over
    /// time; pose; command; sim/vessel) or JSON lines (any channel), on
    /// standard output.
    Export {
        /// An MCAP recording.
        #[arg(value_name = "FILE")]
        file: PathBuf,
        /// The channel (topic) to export, e.g. `/seacover/coverage`,
        /// `/seacover/pose`, `/seacover/command`, `/seacover/events`,
        /// `/seacover/sim/vessel`; `record info` lists a recording's channels.
        #[arg(long, value_name = "TOPIC", default_value = "/seacover/coverage")]
        channel: String,
        /// `csv` (the coverage, pose, command and sim/vessel channels) or
        /// `jsonl` (any channel, one message per line).
        #[arg(long, value_enum, default_value = "csv")]
        format: Format,
    },
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub(crate) enum Format {
    /// Comma-separated values with a header line.
    Csv,
    /// JSON lines: one message per line.
    Jsonl,
}

pub(crate) fn run(command: Command) -> anyhow::Result<()> {
    match command {
        Command::Info { file, json } => {
            let info = inspect::info(&Recording::open(&file)?)?;
            let mut out = std::io::stdout().lock();
            if json {
                serde_json::to_writer_pretty(&mut out, &info)?;
                println!();
            } else {
                inspect::print_info(&info, &mut out)?;
            }
        }
        Command::Export {
            file,
            channel,
            format,
        } => {
            let format = match format {
                Format::Csv => inspect::Format::Csv,
                Format::Jsonl => inspect::Format::Jsonl,
            };
            let mut out = std::io::BufWriter::new(std::io::stdout().lock());
            inspect::export(&Recording::open(&file)?, &channel, format, &mut out)?;
            out.flush()?;
        }
    }
    Ok(())
}
