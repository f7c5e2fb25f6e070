//! The error a command returns when Ctrl-C stopped it after it wrote what it had: `main`
//! prints it and exits with [`lamina_io::interrupt::EXIT_CODE`] (130).

/// A command stopped by Ctrl-C; the message says what was kept.
#[derive(Debug)]
pub struct Interrupted(pub String);

impl std::fmt::Display for Interrupted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "interrupted: {}", self.0)
    }
}

impl std::error::Error for Interrupted {}
