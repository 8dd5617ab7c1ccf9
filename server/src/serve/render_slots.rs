//! Admission and CPU slots for renders (decode + mesh + encode); mesh uploads have a budget
//! of their own of the same kind.
//!
//! Admission is decided on the async side, at once: past `jobs + queue` renders in the
//! system a request is shed with 503. An admitted render then waits for a CPU slot on its
//! blocking-pool thread, not in the async run queue: a slot freed under a flood of requests
//! goes straight to a parked thread instead of idling until the scheduler gets round to the
//! task that was granted it (which starved renders, and goodput fell to a few per second).

use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};
use std::sync::{Arc, Condvar, Mutex, PoisonError};

/// The render budget of one server.
#[derive(Debug)]
pub struct RenderSlots {
    jobs: usize,
    queue: usize,
    /// Renders admitted and not finished: waiting for a slot or running.
    admitted: AtomicUsize,
    running: Mutex<usize>,
    freed: Condvar,
}

impl RenderSlots {
    pub fn new(jobs: usize, queue: usize) -> Self {
        Self {
            jobs: jobs.max(1),
            queue,
            admitted: AtomicUsize::new(0),
            running: Mutex::new(0),
            freed: Condvar::new(),
        }
    }

    /// A ticket for one render, or `None` when `jobs + queue` renders are already in.
    pub fn admit(self: &Arc<Self>) -> Option<Ticket> {
        let before = self.admitted.fetch_add(1, Relaxed);
        let ticket = Ticket(Arc::clone(self));
        // Saturating: `--cpu-jobs` near usize::MAX wrapped the sum to a handful of places.
        (before < self.jobs.saturating_add(self.queue)).then_some(ticket)
    }

    /// Renders admitted and not yet finished.
    pub fn admitted(&self) -> usize {
        self.admitted.load(Relaxed)
    }
}

/// An admitted render; dropping it (after the render, or unused) gives the place back.
#[derive(Debug)]
pub struct Ticket(Arc<RenderSlots>);

impl Ticket {
    /// Runs `f` once a CPU slot is free, blocking this thread until then: call it on the
    /// blocking pool.
    pub fn run<T>(self, f: impl FnOnce() -> T) -> T {
        let s = &self.0;
        {
            let mut running = s.running.lock().unwrap_or_else(PoisonError::into_inner);
            while *running >= s.jobs {
                running = s
                    .freed
                    .wait(running)
                    .unwrap_or_else(PoisonError::into_inner);
            }
            *running += 1;
        }
        // Freed even if `f` panics.
        let _slot = Slot(s);
        f()
    }
}

impl Drop for Ticket {
    fn drop(&mut self) {
        self.0.admitted.fetch_sub(1, Relaxed);
    }
}

struct Slot<'a>(&'a RenderSlots);

impl Drop for Slot<'_> {
    fn drop(&mut self) {
        let mut running = self
            .0
            .running
            .lock()
            .unwrap_or_else(PoisonError::into_inner);
        *running -= 1;
        self.0.freed.notify_one();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn admits_jobs_plus_queue_and_no_more() {
        let s = Arc::new(RenderSlots::new(1, 1));
        let a = s.admit().expect("a slot");
        let b = s.admit().expect("a queue place");
        assert!(s.admit().is_none(), "full: shed");
        drop(a);
        let c = s.admit().expect("a place again");
        drop((b, c));
        assert_eq!(s.admitted(), 0);
    }

    #[test]
    fn runs_at_most_jobs_at_once() {
        let s = Arc::new(RenderSlots::new(2, 64));
        let now = Arc::new(AtomicUsize::new(0));
        let peak = Arc::new(AtomicUsize::new(0));
        let threads: Vec<_> = (0..16)
            .map(|_| {
                let t = s.admit().expect("admitted");
                let (now, peak) = (now.clone(), peak.clone());
                std::thread::spawn(move || {
                    t.run(|| {
                        let n = now.fetch_add(1, Relaxed) + 1;
                        peak.fetch_max(n, Relaxed);
                        std::thread::sleep(std::time::Duration::from_millis(2));
                        now.fetch_sub(1, Relaxed);
                    })
                })
            })
            .collect();
        for t in threads {
            t.join().expect("no panic");
        }
        assert_eq!(peak.load(Relaxed), 2);
        assert_eq!(s.admitted(), 0);
    }

    /// `--jobs 0` still renders, one at a time, rather than shedding every request.
    #[test]
    fn zero_jobs_means_one_render_at_a_time() {
        let s = Arc::new(RenderSlots::new(0, 0));
        let t = s.admit().expect("one render is admitted");
        assert!(s.admit().is_none(), "a second is shed");
        assert_eq!(t.run(|| 7), 7);
        assert_eq!(s.admitted(), 0);
    }

    /// Budgets past usize's range admit without limit instead of wrapping to a few places.
    #[test]
    fn a_huge_budget_does_not_wrap() {
        let s = Arc::new(RenderSlots::new(usize::MAX, 5));
        let tickets: Vec<_> = (0..100).map(|_| s.admit().expect("admitted")).collect();
        assert_eq!(s.admitted(), 100);
        drop(tickets);
        assert_eq!(s.admitted(), 0);
    }

    /// A render that panics frees its CPU slot, so the next render is not stuck forever.
    #[test]
    fn a_render_that_panics_gives_its_slot_back() {
        let s = Arc::new(RenderSlots::new(1, 1));
        let t = s.admit().expect("admitted");
        let panicked = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            t.run(|| panic!("render failed"))
        }));
        assert!(panicked.is_err());
        let next = s.admit().expect("admitted");
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || tx.send(next.run(|| 1)));
        assert_eq!(
            rx.recv_timeout(std::time::Duration::from_secs(10)),
            Ok(1),
            "the next render never got the slot"
        );
    }
}
