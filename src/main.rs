//! The `envlight` command line. Each subcommand lives in its own file under `src/cli/`.

fn main() {
    envlight::cli::main();
}
