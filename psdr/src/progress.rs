//! What a long run is doing, said while it does it. Stages push activities ("unit renders of 12 lights",
//! "yaw sweep of chair_11", "optimise object poses") with their size where it is known; on a terminal the
//! innermost one is a progress bar (a spinner without a size), and where stderr is a file or a pipe (CI logs,
//! `2> run.log`) a reporter thread writes one line at least every `EVERY` seconds: stage, elapsed time, what
//! runs and how far it is. Activities are a stack, so a step inside a step shows the inner one and the outer
//! one returns when it ends. Nothing here changes a result.

use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// A line at least this often where no bar can be drawn.
pub const EVERY: Duration = Duration::from_secs(10);

struct Entry {
    id: u64,
    started: Instant,
    label: String,
    done: u64,
    total: Option<u64>,
    note: Option<String>,
    bar: ProgressBar,
}

#[derive(Default)]
struct State {
    stage: Option<(String, Instant)>,
    stack: Vec<Entry>,
    next_id: u64,
    quiet: bool,
    /// Outermost activities that ended since the last `take_times`: (label, seconds).
    times: Vec<(String, f64)>,
}

static STATE: Mutex<State> =
    Mutex::new(State { stage: None, stack: Vec::new(), next_id: 0, quiet: true, times: Vec::new() });

fn state() -> std::sync::MutexGuard<'static, State> {
    STATE.lock().unwrap_or_else(|e| e.into_inner())
}

/// Says which stage runs (None: between stages); its clock starts now.
pub fn set_stage(name: Option<&str>) {
    state().stage = name.map(|n| (n.to_string(), Instant::now()));
}

/// One step of work, shown while the value lives.
pub struct Activity {
    id: u64,
}

/// Starts an activity: `label` says what runs, `total` how many units it has when known.
pub fn activity(label: impl Into<String>, total: Option<usize>) -> Activity {
    let mut s = state();
    let label = label.into();
    let bar = if s.quiet || !std::io::stderr().is_terminal() {
        ProgressBar::hidden()
    } else {
        let prefix = s.stage.as_ref().map_or(String::new(), |(n, _)| format!("{n}: "));
        let bar = match total {
            Some(n) => {
                let b = ProgressBar::new(n as u64);
                b.set_style(
                    ProgressStyle::with_template("{prefix}{msg} [{bar:30}] {pos}/{len} ({elapsed}, {eta} left)")
                        .unwrap_or_else(|_| ProgressStyle::default_bar()),
                );
                b
            }
            None => {
                let b = ProgressBar::new_spinner();
                b.set_style(
                    ProgressStyle::with_template("{prefix}{msg} {spinner} ({elapsed})")
                        .unwrap_or_else(|_| ProgressStyle::default_spinner()),
                );
                b
            }
        };
        bar.set_prefix(prefix);
        bar.set_message(label.clone());
        bar.enable_steady_tick(Duration::from_millis(250));
        bar
    };
    // Only the innermost activity draws.
    if let Some(outer) = s.stack.last() {
        outer.bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    s.next_id += 1;
    let id = s.next_id;
    s.stack.push(Entry {
        id,
        started: Instant::now(),
        label,
        done: 0,
        total: total.map(|n| n as u64),
        note: None,
        bar,
    });
    Activity { id }
}

impl Activity {
    /// One more unit done.
    pub fn advance(&self) {
        self.set_done_with(|d| d + 1, None);
    }

    /// `done` units done, with a short note ("loss 3.2e-2").
    pub fn set(&self, done: usize, note: Option<String>) {
        self.set_done_with(|_| done as u64, note);
    }

    fn set_done_with(&self, f: impl Fn(u64) -> u64, note: Option<String>) {
        let mut s = state();
        if let Some(e) = s.stack.iter_mut().find(|e| e.id == self.id) {
            e.done = f(e.done);
            e.bar.set_position(e.done);
            if let Some(n) = note {
                e.bar.set_message(format!("{} {n}", e.label));
                e.note = Some(n);
            }
        }
    }
}

impl Drop for Activity {
    fn drop(&mut self) {
        let mut s = state();
        if let Some(i) = s.stack.iter().position(|e| e.id == self.id) {
            let e = s.stack.remove(i);
            e.bar.finish_and_clear();
            // Where a stage's time went: its outermost activities (inner ones are inside those).
            if i == 0 {
                s.times.push((e.label, e.started.elapsed().as_secs_f64()));
            }
        }
        let draw = !s.quiet && std::io::stderr().is_terminal();
        if let (Some(outer), true) = (s.stack.last(), draw) {
            outer.bar.set_draw_target(indicatif::ProgressDrawTarget::stderr());
        }
    }
}

/// The outermost activities that ended since the last call, with their seconds, in order (a stage's phases:
/// `RunContext` takes them when a stage starts and ends).
pub fn take_times() -> Vec<(String, f64)> {
    std::mem::take(&mut state().times)
}

/// The line the reporter writes: "[lights 1:23] unit renders of 12 lights 5/12".
fn status_line(s: &State) -> Option<String> {
    let (stage, started) = s.stage.as_ref()?;
    let t = started.elapsed().as_secs();
    let what = s
        .stack
        .iter()
        .map(|e| {
            let count = e.total.map_or(String::new(), |n| format!(" {}/{n}", e.done));
            let note = e.note.as_ref().map_or(String::new(), |n| format!(" {n}"));
            format!("{}{count}{note}", e.label)
        })
        .collect::<Vec<_>>()
        .join(" > ");
    let what = if what.is_empty() { "working".into() } else { what };
    Some(format!("[{stage} {}:{:02}] {what}", t / 60, t % 60))
}

/// Writes status lines while it lives (where stderr is not a terminal; a terminal has the bars).
pub struct Reporter {
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

/// Starts reporting (`quiet`: no bars, no lines).
pub fn start_reporter(quiet: bool) -> Reporter {
    state().quiet = quiet;
    let stop = Arc::new(AtomicBool::new(false));
    let thread = (!quiet && !std::io::stderr().is_terminal()).then(|| {
        let stop = stop.clone();
        std::thread::spawn(move || {
            let mut last = Instant::now();
            while !stop.load(Ordering::Relaxed) {
                std::thread::sleep(Duration::from_millis(200));
                if last.elapsed() >= EVERY {
                    if let Some(line) = status_line(&state()) {
                        eprintln!("{line}");
                    }
                    last = Instant::now();
                }
            }
        })
    });
    Reporter { stop, thread }
}

impl Drop for Reporter {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        let mut s = state();
        s.quiet = true;
        s.stage = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_status_names_stage_and_nested_activities() {
        set_stage(Some("lights"));
        let outer = activity("unit renders", Some(12));
        outer.advance();
        let inner = activity("light_3", None);
        let line = status_line(&state()).unwrap();
        assert!(line.starts_with("[lights 0:00] unit renders 1/12 > light_3"), "{line}");
        drop(inner);
        outer.set(5, None);
        assert!(status_line(&state()).unwrap().ends_with("unit renders 5/12"));
        drop(outer);
        set_stage(None);
        assert!(status_line(&state()).is_none());
    }
}
