//! `pointsight`: parses the command line and hands over to [`harness::run`]; errors become a
//! message on standard error and exit code 1 here (for a program that embeds the registry and
//! runs scale cells, `harness::experiments::scale::child::cell_entry` does the same).

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    let cli = harness::cli::Cli::parse();
    match harness::run(cli) {
        Ok(code) => code,
        Err(err) => {
            eprintln!("error: {}", harness::guard::error_text(&err));
            ExitCode::FAILURE
        }
    }
}
