//! The `envlight` program: its commands and what each runs.

use super::reports::Bench;
use super::{validation_messages, Global};
use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "envlight",
    version,
    about = "Environment-map lighting on explicit Vulkan passes"
)]
struct Cli {
    #[command(flatten)]
    global: Global,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    Info(super::info::InfoArgs),
    Lights(super::info::LightsArgs),
    Convert(super::maps::ConvertArgs),
    Sh(super::maps::ShArgs),
    Irradiance(super::maps::IrradianceArgs),
    Prefilter(super::maps::PrefilterArgs),
    Demo(super::scene::DemoArgs),
    Render(super::scene::RenderArgs),
    Plan(super::scene::PlanArgs),
    /// List the Vulkan devices and the one envlight would pick
    Devices,
    Report(super::reports::report::ReportArgs),
    Bake(super::bake::BakeArgs),
    /// Benchmarks (GPU time from timestamp queries)
    Bench {
        #[command(subcommand)]
        what: Bench,
    },
}

/// The `envlight` program: parses the command line, runs the command, and exits non-zero
/// on an error or on any validation message.
pub fn main() {
    // Output piped into a reader that stops early (`| head`) ends the process as other Unix
    // tools end, instead of making println! panic on EPIPE.
    #[cfg(unix)]
    // SAFETY: called first, before any thread exists; SIG_DFL is a valid action for SIGPIPE.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    let g = &cli.global;
    let result = match &cli.command {
        Command::Info(a) => super::info::info(a),
        Command::Lights(a) => super::info::lights(a),
        Command::Convert(a) => super::maps::convert(g, a),
        Command::Sh(a) => super::maps::sh(g, a),
        Command::Irradiance(a) => super::maps::irradiance(g, a),
        Command::Prefilter(a) => super::maps::prefilter(g, a),
        Command::Demo(a) => super::scene::demo(g, a),
        Command::Render(a) => super::scene::render(g, a),
        Command::Plan(a) => super::scene::plan(a),
        Command::Devices => super::info::devices(g),
        Command::Report(a) => super::reports::report::report(g, a),
        Command::Bake(a) => super::bake::bake(g, a),
        Command::Bench { what } => super::reports::bench(g, what),
    };
    if let Err(e) = result {
        eprintln!("error: {}", super::error_text(&e));
        // A bake's own codes (schedule::EXIT_*) tell schedulers whether to retry.
        let code = e
            .downcast_ref::<super::schedule::Exit>()
            .map_or(1, |x| x.code);
        std::process::exit(code);
    }
    let messages = validation_messages();
    if !messages.is_empty() {
        eprintln!(
            "error: the Vulkan validation layer reported {} message(s):\n{}",
            messages.len(),
            messages.join("\n")
        );
        std::process::exit(1);
    }
}
