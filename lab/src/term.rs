//! The terminal's side of a command, shared by the command line and the measurement commands:
//! indicatif progress bars, lines for the user on standard output, notices on standard error,
//! each silenced by `--quiet`; and [`Terminal`], the library's [`Report`] drawn that way.

use occlux::progress::{Progress, Report};

/// The library's reports on this terminal: lines through [`say`], a bar per stage.
pub struct Terminal {
    pub quiet: bool,
}

impl Report for Terminal {
    fn say(&self, line: &str) {
        say(self.quiet, line);
    }

    fn stage(&self, label: &str, len: u64) -> Box<dyn Progress + '_> {
        Box::new(Bar::new(self.quiet, len, label))
    }
}

/// The command line's progress bar (indicatif), hidden when quiet: what the CLI's commands hand
/// to the library's long work.
pub struct Bar(indicatif::ProgressBar);

impl Bar {
    /// A bar of `len` units labelled `label`; hidden (drawing nothing) when `quiet`.
    pub fn new(quiet: bool, len: u64, label: &str) -> Self {
        if quiet {
            return Self(indicatif::ProgressBar::hidden());
        }
        let bar = indicatif::ProgressBar::new(len);
        bar.set_style(
            indicatif::ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} {elapsed}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        bar.set_message(label.to_owned());
        Self(bar)
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

    fn message(&self, text: &str) {
        self.0.set_message(text.to_owned());
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

impl Drop for Bar {
    /// A stage's bar leaves the terminal when the stage ends.
    fn drop(&mut self) {
        self.finish();
    }
}
