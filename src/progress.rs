//! Progress reporting from the library: a callback, so the CLI can drive a progress bar and the
//! Blender add-on its own progress API.

/// Receives `(done, total)` in units the caller chose (rows, slices, steps), and may ask the
/// work to stop: long computations check [`Progress::cancelled`] between units and then return
/// [`crate::Error::Cancelled`] without a result.
pub trait Progress: Sync {
    fn update(&self, done: u64, total: u64);

    /// What the work is at now ("frame 3"), for a caller that shows it.
    fn message(&self, _text: &str) {}

    /// Whether the caller wants the work abandoned.
    fn cancelled(&self) -> bool {
        false
    }
}

/// Reports nothing.
pub struct NoProgress;

impl Progress for NoProgress {
    fn update(&self, _done: u64, _total: u64) {}
}

/// One part of a longer piece of work: its units counted from `offset` within `total`, and the
/// caller's cancellation passed through.
pub struct Part<'a> {
    pub whole: &'a dyn Progress,
    pub offset: u64,
    pub total: u64,
}

impl Progress for Part<'_> {
    fn update(&self, done: u64, _total: u64) {
        self.whole.update(self.offset + done, self.total)
    }

    fn cancelled(&self) -> bool {
        self.whole.cancelled()
    }
}

/// Passes the caller's cancellation through and reports nothing: for a step whose units do
/// not match the caller's.
pub struct Cancel<'a>(pub &'a dyn Progress);

impl Progress for Cancel<'_> {
    fn update(&self, _done: u64, _total: u64) {}

    fn cancelled(&self) -> bool {
        self.0.cancelled()
    }
}

impl<F: Fn(u64, u64) + Sync> Progress for F {
    fn update(&self, done: u64, total: u64) {
        self(done, total)
    }
}

/// Where long library work tells its caller how it goes: lines for the user (what it settled
/// and why) and a progress per stage. The command line prints and draws bars; Python and tests
/// pass [`Silent`].
pub trait Report: Sync {
    /// A line for the user.
    fn say(&self, line: &str);

    /// The progress of one stage of `len` units labelled `label`; the stage ends when it is
    /// dropped.
    fn stage(&self, label: &str, len: u64) -> Box<dyn Progress + '_>;
}

/// Reports nothing.
pub struct Silent;

impl Report for Silent {
    fn say(&self, _line: &str) {}

    fn stage(&self, _label: &str, _len: u64) -> Box<dyn Progress + '_> {
        Box::new(NoProgress)
    }
}
