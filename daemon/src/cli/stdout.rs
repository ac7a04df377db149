//! Standard output for the command line. `println!` panics when the reader has gone
//! (`pulsetrack status | head -1`); here a closed pipe ends the program quietly with status 0,
//! as Unix tools do, and any other write error is reported once with status 1.

use std::io::Write;

/// Write one formatted line and flush it (progress lines must show at once).
pub fn line(args: std::fmt::Arguments<'_>) {
    let mut out = std::io::stdout().lock();
    let written = out
        .write_fmt(args)
        .and_then(|()| out.write_all(b"\n"))
        .and_then(|()| out.flush());
    if let Err(e) = written {
        drop(out);
        stop(&e);
    }
}

/// Write bytes as they are (a generated script or page) and flush them.
pub fn bytes(b: &[u8]) {
    let mut out = std::io::stdout().lock();
    if let Err(e) = out.write_all(b).and_then(|()| out.flush()) {
        drop(out);
        stop(&e);
    }
}

fn stop(e: &std::io::Error) -> ! {
    if e.kind() == std::io::ErrorKind::BrokenPipe {
        std::process::exit(0);
    }
    eprintln!("pulsetrack: cannot write to standard output: {e}");
    std::process::exit(1);
}

/// `println!` for the command line, without the panic on a closed pipe.
macro_rules! outln {
    () => {
        $crate::cli::stdout::line(format_args!(""))
    };
    ($($arg:tt)*) => {
        $crate::cli::stdout::line(format_args!($($arg)*))
    };
}
pub(crate) use outln;
