//! Child processes with a time limit and a cancel flag.
//!
//! A solver runs as `z3 -in -smt2 -T:<seconds>` (the timeout rounded up to whole seconds, at
//! least 1) or `cvc5 --lang=smt2 --tlimit=<timeout ms + 1000>` (see [`super::Solver`]). The
//! solver's own limit is only a backstop for when this process dies: the timeout is enforced
//! here, by killing the child at the deadline and reaping it. The cancel flag (set by the
//! portfolio when the run's answer is no longer needed) is polled with the exit status, so a
//! cancelled child is killed within about 10 ms. Standard input is fed and standard output and
//! error are drained by helper threads, so no pipe can fill up. (A solver that exits without
//! reading all its input makes the feeding write fail with `EPIPE`; that is harmless because
//! Rust programs ignore `SIGPIPE`, as std sets up before `main`.)

use std::io::{self, Read, Write};
use std::process::{Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::thread;
use std::time::{Duration, Instant};

/// How long `--version` may take before the binary is considered unusable.
const VERSION_TIMEOUT: Duration = Duration::from_secs(10);

/// At most this much of a child's stdout or stderr is kept; the rest is read and dropped.
const OUTPUT_LIMIT: u64 = 16 << 20;

/// How long to wait for the output readers once the child has been reaped (they only outlive
/// it if something else holds the pipes open).
const DRAIN_GRACE: Duration = Duration::from_secs(2);

/// A child process that has been reaped.
#[derive(Debug)]
pub(super) struct Finished {
    /// Its standard output (lossily decoded).
    pub(super) stdout: String,
    /// Its standard error (lossily decoded).
    pub(super) stderr: String,
    /// Its exit status, if `wait` reported one.
    pub(super) status: Option<ExitStatus>,
    /// Whether the deadline passed and it was killed.
    pub(super) timed_out: bool,
    /// Whether it was killed because its group was already proved.
    pub(super) cancelled: bool,
    /// Its process id (for tests checking that it is gone).
    #[cfg_attr(not(test), allow(dead_code))]
    pub(super) pid: u32,
}

/// Runs `program args`, feeding `input` on stdin, and kills it once `timeout` has passed.
/// The child is always reaped before this returns; `Err` only when it could not be started.
pub(super) fn run_process(
    program: &str,
    args: &[String],
    input: &str,
    timeout: Duration,
    cancel: Option<&AtomicBool>,
) -> io::Result<Finished> {
    let start = Instant::now();
    let mut child = Command::new(program)
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()?;
    let pid = child.id();

    let helpers = (|| -> io::Result<_> {
        let stdin = child.stdin.take();
        let input = input.as_bytes().to_vec();
        // The writer is detached: once the child is gone its write fails and it ends.
        thread::Builder::new()
            .name("qloop-smt-stdin".to_string())
            .spawn(move || {
                if let Some(mut stdin) = stdin {
                    // A solver that exits early (say on a parse error) closes the pipe.
                    let _ = stdin.write_all(&input);
                }
            })?;
        let out = spawn_reader(child.stdout.take())?;
        let err = spawn_reader(child.stderr.take())?;
        Ok((out, err))
    })();
    let (out_rx, err_rx) = match helpers {
        Ok(rxs) => rxs,
        Err(e) => {
            let _ = child.kill();
            let _ = child.wait();
            return Err(e);
        }
    };

    // A timeout too large to represent means no deadline.
    let deadline = start.checked_add(timeout);
    let mut nap = Duration::from_millis(1);
    let mut cancelled = false;
    let (status, timed_out) = loop {
        if cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
            let _ = child.kill();
            cancelled = true;
            break (child.wait().ok(), false);
        }
        match child.try_wait() {
            Ok(Some(status)) => break (Some(status), false),
            Ok(None) => {}
            Err(_) => {
                // Cannot poll: fall back to a blocking wait (the solver's own limit ends it).
                break (child.wait().ok(), false);
            }
        }
        let now = Instant::now();
        let left = match deadline {
            Some(deadline) if now >= deadline => {
                let _ = child.kill();
                break (child.wait().ok(), true);
            }
            Some(deadline) => deadline - now,
            None => nap,
        };
        thread::sleep(nap.min(left));
        nap = (nap * 2).min(Duration::from_millis(10));
    };

    let collect = |rx: mpsc::Receiver<Vec<u8>>| {
        rx.recv_timeout(DRAIN_GRACE)
            .map(|bytes| String::from_utf8_lossy(&bytes).into_owned())
            .unwrap_or_default()
    };
    Ok(Finished {
        stdout: collect(out_rx),
        stderr: collect(err_rx),
        status,
        timed_out,
        cancelled,
        pid,
    })
}

/// Reads `pipe` to the end on a thread; the bytes (up to [`OUTPUT_LIMIT`]) arrive on the
/// returned channel.
fn spawn_reader<R: Read + Send + 'static>(pipe: Option<R>) -> io::Result<mpsc::Receiver<Vec<u8>>> {
    let (tx, rx) = mpsc::channel();
    if let Some(mut pipe) = pipe {
        thread::Builder::new()
            .name("qloop-smt-output".to_string())
            .spawn(move || {
                let mut bytes = Vec::new();
                let _ = (&mut pipe).take(OUTPUT_LIMIT).read_to_end(&mut bytes);
                let _ = io::copy(&mut pipe, &mut io::sink());
                let _ = tx.send(bytes);
            })?;
    }
    Ok(rx)
}

/// The first line of `program --version`, if it runs, exits successfully and prints one.
pub(super) fn probe_version(program: &str) -> Option<String> {
    let fin = run_process(
        program,
        &["--version".to_string()],
        "",
        VERSION_TIMEOUT,
        None,
    )
    .ok()?;
    if fin.timed_out || !fin.status.is_some_and(|s| s.success()) {
        return None;
    }
    let line = fin.stdout.lines().map(str::trim).find(|l| !l.is_empty())?;
    Some(line.to_string())
}
