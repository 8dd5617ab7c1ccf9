//! The `zerotile` command line.

fn main() -> std::process::ExitCode {
    zerotile::cli::run()
}
