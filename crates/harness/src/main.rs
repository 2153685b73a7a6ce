//! `pointsight`: makes itself the subreaper of its descendants, parses the command line and
//! hands over to [`harness::run`]; errors become a message on standard error and exit code 1
//! here (for a program that embeds the registry and
//! runs scale cells, `harness::experiments::scale::child::cell_entry` does the same).

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    // The subreaper of whatever the external methods start: a descendant that leaves its
    // method's process group (`setsid`, a double fork), killed with its method by its
    // method's token (the registry's `external::session`), is reparented here rather than to
    // init and reaped here. Python's `import pointsight` sets none (docs/python.md).
    let _ = nix::sys::prctl::set_child_subreaper(true);
    let cli = harness::cli::Cli::parse();
    match harness::run(cli) {
        Ok(code) => code,
        Err(err) => {
            eprintln!("error: {}", harness::guard::error_text(&err));
            ExitCode::FAILURE
        }
    }
}
