//! SIGINT and SIGTERM: remove what the run would leave behind — temporary
//! files, staging folders, output locks (`formats::interrupt`) — then end
//! with status 128 + the signal's number, as a shell reports a process
//! killed by it. Files already renamed into place stay; `measure` keeps its
//! partial output and resumes when started again.

/// Handle SIGINT and SIGTERM on a thread of their own (signal-hook's
/// iterator: the handler itself only wakes that thread, so the clean-up runs
/// outside signal context and may lock and remove files). `rerun` is what
/// the message says a rerun of the command does, where it does more than
/// start again (`measure` resumes).
#[cfg(unix)]
pub fn install(rerun: Option<&'static str>) {
    use std::io::Write;

    use signal_hook::consts::{SIGINT, SIGTERM};
    use signal_hook::iterator::Signals;

    let mut signals = match Signals::new([SIGINT, SIGTERM]) {
        Ok(s) => s,
        Err(e) => {
            eprintln!(
                "trinocular: warning: cannot handle SIGINT/SIGTERM ({e}); an interrupted run may leave temporary files"
            );
            return;
        }
    };
    std::thread::spawn(move || {
        if let Some(signal) = signals.forever().next() {
            let name = if signal == SIGINT {
                "SIGINT"
            } else {
                "SIGTERM"
            };
            formats::interrupt::clean_up_then(|removed| {
                // Written, not eprintln!: a closed stderr (a pipe whose reader
                // left) must not stop the exit below with a panic.
                let _ = writeln!(
                    std::io::stderr(),
                    "trinocular: interrupted by {name}; {removed} temporary file{} removed{}",
                    if removed == 1 { "" } else { "s" },
                    rerun.map(|r| format!("; {r}")).unwrap_or_default()
                );
                std::process::exit(128 + signal)
            });
        }
    });
}

/// Signals are not handled on this platform.
#[cfg(not(unix))]
pub fn install(_rerun: Option<&'static str>) {}
