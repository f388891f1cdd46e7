fn main() -> std::process::ExitCode {
    psdr::cli::main()
}
