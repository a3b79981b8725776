//! Runs `cargo kani` in its own process group and kills the whole group (cargo, kani-driver,
//! CBMC) at a deadline; output is drained by helper threads so no pipe fills up.

use std::io::Read;
use std::os::unix::process::CommandExt;
use std::process::{Command, Stdio};
use std::thread;
use std::time::{Duration, Instant};

/// A finished (or killed) run.
pub struct Done {
    /// Standard output.
    pub stdout: String,
    /// Standard error.
    pub stderr: String,
    /// Whether the deadline passed and the group was killed.
    pub killed: bool,
}

/// Runs `program args` until it exits or `deadline` passes.
pub fn run(program: &str, args: &[String], deadline: Duration) -> std::io::Result<Done> {
    let mut child = Command::new(program)
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .process_group(0)
        .spawn()?;
    let drain = |r: Option<Box<dyn Read + Send>>| {
        thread::spawn(move || {
            let mut s = String::new();
            if let Some(mut r) = r {
                let mut b = Vec::new();
                let _ = r.read_to_end(&mut b);
                s = String::from_utf8_lossy(&b).into_owned();
            }
            s
        })
    };
    let out = drain(
        child
            .stdout
            .take()
            .map(|r| Box::new(r) as Box<dyn Read + Send>),
    );
    let err = drain(
        child
            .stderr
            .take()
            .map(|r| Box::new(r) as Box<dyn Read + Send>),
    );
    let start = Instant::now();
    let mut killed = false;
    loop {
        if child.try_wait()?.is_some() {
            break;
        }
        if start.elapsed() >= deadline {
            // The group: cargo, kani-driver and CBMC (no `libc` dependency for one kill).
            let _ = Command::new("kill")
                .args(["-KILL", "--", &format!("-{}", child.id())])
                .status();
            let _ = child.kill();
            let _ = child.wait();
            killed = true;
            break;
        }
        thread::sleep(Duration::from_millis(100));
    }
    // Leftovers of the group: when Kani stops CBMC at its own time limit, an SMT solver CBMC
    // started (the `model_matches_*` harnesses run on cvc5) keeps running otherwise.
    let _ = Command::new("kill")
        .args(["-KILL", "--", &format!("-{}", child.id())])
        .stderr(Stdio::null())
        .status();
    Ok(Done {
        stdout: out.join().unwrap_or_default(),
        stderr: err.join().unwrap_or_default(),
        killed,
    })
}
