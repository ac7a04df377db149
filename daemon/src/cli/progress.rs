//! Progress of long work (`fem`, `bench`, `demo`) on stderr: an indicatif bar or spinner when
//! stderr is a terminal, plain whole lines otherwise (a log file or a pipe never gets cursor
//! codes or carriage returns). Never on stdout, which carries the results and `--json`'s
//! document.

use std::io::IsTerminal;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// One piece of long work.
#[derive(Debug)]
pub struct Progress {
    what: String,
    total: Option<u64>,
    done: AtomicU64,
    bar: Option<ProgressBar>,
    started: Instant,
    /// Stops the plain-mode heartbeat thread of [`Progress::heartbeat`].
    beating: Arc<AtomicBool>,
}

impl Progress {
    /// `total` steps of `what` (None: a spinner), drawn as fits stderr.
    pub fn new(what: &str, total: Option<u64>) -> Self {
        Self::on(what, total, std::io::stderr().is_terminal())
    }

    /// The same, told whether stderr is a terminal (tests).
    pub fn on(what: &str, total: Option<u64>, terminal: bool) -> Self {
        let bar = terminal.then(|| {
            let bar = match total {
                Some(n) => ProgressBar::with_draw_target(Some(n), ProgressDrawTarget::stderr()),
                None => ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr()),
            };
            let template = match total {
                Some(_) => "{prefix} [{elapsed_precise}] {wide_bar} {pos}/{len} {msg}",
                None => "{prefix} [{elapsed_precise}] {spinner} {msg}",
            };
            if let Ok(style) = ProgressStyle::with_template(template) {
                bar.set_style(style);
            }
            bar.set_prefix(what.to_string());
            if total.is_none() {
                bar.enable_steady_tick(Duration::from_millis(200));
            }
            bar
        });
        Self {
            what: what.to_string(),
            total,
            done: AtomicU64::new(0),
            bar,
            started: Instant::now(),
            beating: Arc::new(AtomicBool::new(false)),
        }
    }

    /// One step done (from any thread); `note` says which.
    pub fn step(&self, note: &str) {
        let n = self.done.fetch_add(1, Ordering::Relaxed) + 1;
        match &self.bar {
            Some(bar) => {
                bar.inc(1);
                bar.set_message(note.to_string());
            }
            None => eprintln!("{}", plain_line(&self.what, n, self.total, note)),
        }
    }

    /// What is going on now (the spinner's message; a plain line without a terminal).
    pub fn status(&self, note: &str) {
        match &self.bar {
            Some(bar) => bar.set_message(note.to_string()),
            None => eprintln!("{}: {note}", self.what),
        }
    }

    /// Without a terminal, a line every `every` saying the work goes on (work with no
    /// steps to count, such as one long solve), until [`Progress::finish`].
    pub fn heartbeat(&self, every: Duration) {
        if self.bar.is_some() || self.beating.swap(true, Ordering::SeqCst) {
            return;
        }
        let beating = Arc::clone(&self.beating);
        let what = self.what.clone();
        let started = self.started;
        std::thread::spawn(move || {
            // Checked often so that a finished piece of work stops it at once.
            let mut last = Instant::now();
            while beating.load(Ordering::SeqCst) {
                std::thread::sleep(Duration::from_millis(100));
                if last.elapsed() >= every && beating.load(Ordering::SeqCst) {
                    last = Instant::now();
                    eprintln!(
                        "{what}: still running, {:.0} s",
                        started.elapsed().as_secs_f64()
                    );
                }
            }
        });
    }

    /// A line for stderr that must not tear the bar.
    pub fn note(&self, line: &str) {
        match &self.bar {
            Some(bar) => bar.println(line),
            None => eprintln!("{line}"),
        }
    }

    /// Run `f` (which writes to stdout) with the bar cleared meanwhile.
    pub fn suspend<R>(&self, f: impl FnOnce() -> R) -> R {
        match &self.bar {
            Some(bar) => bar.suspend(f),
            None => f(),
        }
    }

    /// The work is over: the bar is removed, the heartbeat stops.
    pub fn finish(&self) {
        self.beating.store(false, Ordering::SeqCst);
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.finish();
    }
}

/// A step's line without a terminal: `bench 3/28: seed-arc-145 beatslide seed 2: completed`.
pub fn plain_line(what: &str, n: u64, total: Option<u64>, note: &str) -> String {
    let count = match total {
        Some(t) => format!("{n}/{t}"),
        None => n.to_string(),
    };
    if note.is_empty() {
        format!("{what} {count}")
    } else {
        format!("{what} {count}: {note}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plain_lines_count_the_steps() {
        assert_eq!(
            plain_line(
                "bench",
                3,
                Some(28),
                "seed-arc-145 beatslide seed 2: completed"
            ),
            "bench 3/28: seed-arc-145 beatslide seed 2: completed"
        );
        assert_eq!(plain_line("fem", 2, None, ""), "fem 2");
    }

    #[test]
    fn without_a_terminal_there_is_no_bar() {
        let p = Progress::on("bench", Some(2), false);
        assert!(p.bar.is_none());
        p.step("one");
        p.step("two");
        assert_eq!(p.done.load(Ordering::Relaxed), 2);
        assert_eq!(p.suspend(|| 7), 7);
        p.finish();
        let t = Progress::on("bench", Some(2), true);
        assert!(t.bar.is_some());
    }
}
