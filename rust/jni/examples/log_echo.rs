//! Reads a log with fpbp-logs (strict: the first malformed line is an error)
//! and writes its events back as a native v1 log. The JVM host tests use it to
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
    let (events, _) =
        fpbp_logs::read_all(std::path::Path::new(input), &opts).map_err(|e| e.to_string())?;
    let file = std::fs::File::create(output).map_err(|e| format!("{output}: {e}"))?;
    let mut w = fpbp_logs::native::NativeWriter::new(
        std::io::BufWriter::new(file),
        &fpbp_logs::native::NativeHeader::new(),
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
