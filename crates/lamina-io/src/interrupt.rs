//! One Ctrl-C policy for the whole process.
//!
//! The rule every lamina command follows (README, "Stopping a render"):
//!
//! * [`install`] puts in the process's one handler before any work starts (the `ctrlc`
//!   crate allows one per process; installing again is a no-op).
//! * While there is nothing to write yet (loading a scene, building the BVH, a render's
//!   first pass, making a leaf folder, growing a plant) the process is in
//!   [`Mode::Quit`]: Ctrl-C removes the temporary files in flight and ends the process
//!   at once with exit code [`EXIT_CODE`] (130, the shell's convention for SIGINT). Nothing
//!   is written and existing outputs are untouched.
//! * Once there is something worth keeping (a render with at least one completed pass) the
//!   command switches to [`Mode::Stop`]: the first Ctrl-C only raises the flag returned by
//!   [`flag`]; the renderer drops the pass in progress, the command writes the image of the
//!   completed passes, prints how many made it, and exits with 130.
//! * A second Ctrl-C always ends the process at once (temporary files removed).
//! * A commit of an output ([`critical`]) is never cut in half: a Ctrl-C that would end the
//!   process during one takes effect when it is done.

use std::sync::atomic::{AtomicBool, AtomicU8, AtomicU32, Ordering};
use std::sync::{Arc, OnceLock};

/// The exit code of a command stopped by Ctrl-C (128 + SIGINT).
pub const EXIT_CODE: u8 = 130;

/// What the next Ctrl-C does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// End the process at once (nothing to write yet).
    Quit,
    /// Raise [`flag`] so that the command stops at its next safe point and writes what it
    /// has; a second Ctrl-C ends the process at once.
    Stop,
}

static MODE: AtomicU8 = AtomicU8::new(0);
static PRESSES: AtomicU32 = AtomicU32::new(0);
static CRITICAL: AtomicU32 = AtomicU32::new(0);
static QUIT_PENDING: AtomicBool = AtomicBool::new(false);
static FLAG: OnceLock<Arc<AtomicBool>> = OnceLock::new();
static INSTALLED: OnceLock<Result<(), String>> = OnceLock::new();

/// The flag that a Ctrl-C in [`Mode::Stop`] raises (shared by every render of the process,
/// e.g. the demo's three panels).
pub fn flag() -> Arc<AtomicBool> {
    FLAG.get_or_init(|| Arc::new(AtomicBool::new(false)))
        .clone()
}

/// Whether Ctrl-C was pressed since the process started.
pub fn interrupted() -> bool {
    PRESSES.load(Ordering::SeqCst) > 0
}

/// Sets what the next Ctrl-C does.
pub fn set_mode(mode: Mode) {
    MODE.store(
        match mode {
            Mode::Quit => 0,
            Mode::Stop => 1,
        },
        Ordering::SeqCst,
    );
}

/// What the next Ctrl-C does now.
pub fn mode() -> Mode {
    if MODE.load(Ordering::SeqCst) == 0 {
        Mode::Quit
    } else {
        Mode::Stop
    }
}

/// Installs the process's Ctrl-C handler (idempotent), in [`Mode::Quit`]. Call it first
/// thing in `main`.
pub fn install() -> Result<(), String> {
    INSTALLED
        .get_or_init(|| {
            let _ = flag();
            ctrlc::set_handler(on_ctrl_c)
                .map_err(|e| format!("cannot install the Ctrl-C handler: {e}"))
        })
        .clone()
}

/// Runs `f`, deferring a Ctrl-C that would end the process until `f` returns (then the
/// process ends with [`EXIT_CODE`]). For the few milliseconds of committing an output.
pub fn critical<R>(f: impl FnOnce() -> R) -> R {
    struct Guard;
    impl Drop for Guard {
        fn drop(&mut self) {
            if CRITICAL.fetch_sub(1, Ordering::SeqCst) == 1 && QUIT_PENDING.load(Ordering::SeqCst) {
                quit_now();
            }
        }
    }
    CRITICAL.fetch_add(1, Ordering::SeqCst);
    let _guard = Guard;
    f()
}

fn on_ctrl_c() {
    let presses = PRESSES.fetch_add(1, Ordering::SeqCst) + 1;
    if presses == 1 && mode() == Mode::Stop {
        flag().store(true, Ordering::SeqCst);
        eprintln!("\ninterrupted: stopping at the next safe point (Ctrl-C again to quit at once)");
        return;
    }
    if CRITICAL.load(Ordering::SeqCst) > 0 {
        QUIT_PENDING.store(true, Ordering::SeqCst);
        return;
    }
    quit_now();
}

fn quit_now() -> ! {
    crate::atomic::remove_temporaries();
    eprintln!("\ninterrupted: stopped, nothing written");
    std::process::exit(EXIT_CODE as i32);
}
