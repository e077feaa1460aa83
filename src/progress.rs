//! Progress reporting from the library: a callback, so the CLI can drive a progress bar and the
//! Blender add-on its own progress API.

/// Receives `(done, total)` in units the caller chose (rows, slices, steps), and may ask the
/// work to stop: long computations check [`Progress::cancelled`] between units and then return
/// [`crate::Error::Cancelled`] without a result.
pub trait Progress: Sync {
    fn update(&self, done: u64, total: u64);

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

impl<F: Fn(u64, u64) + Sync> Progress for F {
    fn update(&self, done: u64, total: u64) {
        self(done, total)
    }
}

/// The command line's progress bar (indicatif), hidden when quiet: what the CLI's commands hand
/// to the library's long work.
pub struct Bar(indicatif::ProgressBar);

impl Bar {
    /// A bar of `len` units labelled `label`; hidden (drawing nothing) when `quiet`.
    pub fn new(quiet: bool, len: u64, label: &'static str) -> Self {
        if quiet {
            return Self(indicatif::ProgressBar::hidden());
        }
        let bar = indicatif::ProgressBar::new(len);
        bar.set_style(
            indicatif::ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} {elapsed}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        bar.set_message(label);
        Self(bar)
    }

    /// Shows what the bar's work is at now.
    pub fn message(&self, text: &str) {
        self.0.set_message(text.to_owned());
    }

    /// Removes the bar from the terminal.
    pub fn finish(&self) {
        self.0.finish_and_clear();
    }
}

impl Progress for Bar {
    fn update(&self, done: u64, total: u64) {
        self.0.set_length(total);
        self.0.set_position(done);
    }
}

/// Prints a line for the user unless `quiet`.
pub fn say(quiet: bool, line: impl std::fmt::Display) {
    if !quiet {
        println!("{line}");
    }
}

/// Lists the files a command wrote, unless `quiet`.
pub fn report_written(paths: &[std::path::PathBuf], quiet: bool) {
    for path in paths {
        say(quiet, format_args!("wrote {}", path.display()));
    }
}

/// Prints a notice (which device was picked, and why) on standard error unless `quiet`.
pub fn notice(quiet: bool, line: impl std::fmt::Display) {
    if !quiet {
        eprintln!("{line}");
    }
}
