//! The `revelio` binary: everything lives in the library (`revelio::cli`), so tests and the
//! benches drive the same code the command line runs.
fn main() -> std::process::ExitCode {
    revelio::cli::main()
}
