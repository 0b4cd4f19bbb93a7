//! Reads a log with fpbp-logs (strict: the first malformed line is an error)
//! and writes its events back as a native log of the input's version (v1 in,
//! v1 out, so a reader that knows only v1 reads it back; v2 otherwise). The JVM host tests use it to
//! check that logs written by the Kotlin recorder (`io.fpbp.NativeLogWriter`)
//! parse with the Rust reader to the very same values.
//!
//! Usage: `log_echo IN OUT`

use std::process::ExitCode;

fn run() -> Result<usize, String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [input, output] = args.as_slice() else {
        return Err("usage: log_echo IN OUT".into());
    };
    let opts = fpbp_logs::ReadOptions {
        strict: true,
        ..Default::default()
    };
    let mut r =
        fpbp_logs::open_log(std::path::Path::new(input), &opts).map_err(|e| e.to_string())?;
    let mut events = Vec::new();
    while let Some(e) = r.try_next().map_err(|e| e.to_string())? {
        events.push(e);
    }
    let version = r.native_version().unwrap_or(fpbp_logs::native::VERSION);
    let file = std::fs::File::create(output).map_err(|e| format!("{output}: {e}"))?;
    let mut w = fpbp_logs::native::NativeWriter::with_version(
        std::io::BufWriter::new(file),
        &fpbp_logs::native::NativeHeader::new(),
        version,
    )
    .map_err(|e| format!("{output}: {e}"))?;
    for e in &events {
        w.write(e).map_err(|e| format!("{output}: {e}"))?;
    }
    w.finish().map_err(|e| format!("{output}: {e}"))?;
    Ok(events.len())
}

fn main() -> ExitCode {
    match run() {
        Ok(n) => {
            eprintln!("log_echo: {n} events");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("log_echo: {e}");
            ExitCode::FAILURE
        }
    }
}
