fn main() -> std::process::ExitCode {
    revelio::cli::main()
}
