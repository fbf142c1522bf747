//! Lines on stderr that cannot stop a command (issue 39). `eprintln!`
//! panics when the write fails, and it fails as soon as the reader of
//! stderr is gone (`normalnet batch … 2>&1 | head -3`, a log collector that
//! died, a closed terminal): a progress line or a warning then aborted a
//! batch half done. Every line the program writes on stderr goes through
//! `stderr_line!`, which drops a line that cannot be written: a message
//! nobody can read is not worth the work. `clippy::print_stderr` is denied
//! in the program, so that no `eprintln!` comes back.

/// `eprintln!` without the panic: formats like `println!`, writes the line
/// to stderr and ignores any write error. (`#[macro_use]` in `main.rs`:
/// every module of the program has it.)
macro_rules! stderr_line {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($arg)*);
    }};
}
