//! `Bar`: the `normalnet_mesh::Progress` of every command. On a terminal an
//! indicatif bar with ETA; when stderr is not a terminal (a log under nohup,
//! a pipe) plain lines with position, ETA and the last message every
//! [`LINE_SECONDS`] (`NORMALNET_PROGRESS_SECONDS` overrides it), the first
//! one only once a task has run that long, so quick commands stay silent;
//! nothing with `--quiet`. Neither can panic on a closed stderr (issue
//! 39): plain lines go through `stderr_line!`, and indicatif drops its
//! draw errors in every call made here (not in `set_tab_width`, which
//! unwraps them: not to be used).

use indicatif::{ProgressBar, ProgressStyle};
use normalnet_mesh::Progress;
use std::io::IsTerminal;
use std::sync::Mutex;
use std::time::Instant;

/// Seconds between two plain progress lines (and before the first).
pub const LINE_SECONDS: f64 = 10.0;

/// Environment variable overriding [`LINE_SECONDS`].
pub const LINE_SECONDS_ENV: &str = "NORMALNET_PROGRESS_SECONDS";

/// Where progress goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mode {
    Hidden,
    Terminal,
    Lines,
}

/// The task being reported in [`Mode::Lines`].
#[derive(Default)]
struct LineTask {
    label: String,
    total: u64,
    pos: u64,
    message: String,
    started: Option<Instant>,
    printed: Option<Instant>,
}

/// Progress on stderr: a bar, plain lines, or nothing.
pub struct Bar {
    mode: Mode,
    every: f64,
    created: Instant,
    bar: Mutex<Option<ProgressBar>>,
    line: Mutex<LineTask>,
}

impl Bar {
    /// A bar on a terminal, plain lines elsewhere, nothing when `quiet`.
    pub fn new(quiet: bool) -> Bar {
        let mode = if quiet {
            Mode::Hidden
        } else if std::io::stderr().is_terminal() {
            Mode::Terminal
        } else {
            Mode::Lines
        };
        let every = std::env::var(LINE_SECONDS_ENV)
            .ok()
            .and_then(|v| v.parse::<f64>().ok())
            .filter(|v| v.is_finite() && *v >= 0.0)
            .unwrap_or(LINE_SECONDS);
        Bar {
            mode,
            every,
            created: Instant::now(),
            bar: Mutex::new(None),
            line: Mutex::new(LineTask::default()),
        }
    }

    fn print_line(&self, task: &LineTask, done: bool) {
        let now = self.created.elapsed().as_secs_f64();
        let spent = task.started.map_or(0.0, |t| t.elapsed().as_secs_f64());
        let state = if done {
            format!("done in {spent:.0} s")
        } else if task.total > 0 {
            let pct = 100.0 * task.pos as f64 / task.total as f64;
            let eta = if task.pos > 0 {
                format!(
                    "ETA {:.0} s",
                    spent / task.pos as f64 * task.total.saturating_sub(task.pos) as f64
                )
            } else {
                "ETA ?".into()
            };
            format!("{}/{} ({pct:.0}%) {eta}", task.pos, task.total)
        } else {
            format!("{}", task.pos)
        };
        let sep = if task.message.is_empty() { "" } else { " · " };
        stderr_line!(
            "[{now:>6.0} s] {}: {state}{sep}{}",
            task.label,
            task.message
        );
    }

    /// Prints the current line when the last one (or the task's start) is
    /// old enough.
    fn maybe_print(&self, task: &mut LineTask) {
        let since = task.printed.or(task.started);
        if since.is_none_or(|t| t.elapsed().as_secs_f64() >= self.every) {
            self.print_line(task, false);
            task.printed = Some(Instant::now());
        }
    }

    fn line(&self) -> std::sync::MutexGuard<'_, LineTask> {
        self.line.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn bar(&self) -> std::sync::MutexGuard<'_, Option<ProgressBar>> {
        self.bar.lock().unwrap_or_else(|e| e.into_inner())
    }
}

impl Progress for Bar {
    fn start(&self, label: &str, total: u64) {
        match self.mode {
            Mode::Hidden => {}
            Mode::Terminal => {
                let bar = ProgressBar::new(total);
                bar.set_style(
                    ProgressStyle::with_template(
                        "{prefix:>12} [{bar:30}] {pos}/{len} {elapsed_precise} ETA {eta} {msg}",
                    )
                    .unwrap_or_else(|_| ProgressStyle::default_bar())
                    .progress_chars("=> "),
                );
                bar.set_prefix(label.to_string());
                if let Some(old) = self.bar().replace(bar) {
                    old.finish_and_clear();
                }
            }
            Mode::Lines => {
                let mut task = self.line();
                *task = LineTask {
                    label: label.to_string(),
                    total,
                    started: Some(Instant::now()),
                    ..LineTask::default()
                };
                self.maybe_print(&mut task);
            }
        }
    }

    fn advance(&self, n: u64) {
        match self.mode {
            Mode::Hidden => {}
            Mode::Terminal => {
                if let Some(b) = self.bar().as_ref() {
                    b.inc(n);
                }
            }
            Mode::Lines => {
                let mut task = self.line();
                task.pos += n;
                self.maybe_print(&mut task);
            }
        }
    }

    fn message(&self, text: &str) {
        match self.mode {
            Mode::Hidden => {}
            Mode::Terminal => {
                if let Some(b) = self.bar().as_ref() {
                    b.set_message(text.to_string());
                }
            }
            Mode::Lines => {
                let mut task = self.line();
                task.message = text.to_string();
                self.maybe_print(&mut task);
            }
        }
    }

    fn finish(&self) {
        match self.mode {
            Mode::Hidden => {}
            Mode::Terminal => {
                if let Some(b) = self.bar().take() {
                    b.finish_and_clear();
                }
            }
            Mode::Lines => {
                let mut task = self.line();
                if task.printed.is_some() {
                    self.print_line(&task, true);
                }
                *task = LineTask::default();
            }
        }
    }
}
