//! Where the library's parallel work starts: [`on_pool`] runs a call on a thread of rayon's
//! global pool with a second thread kept awake for it. The numbers never depend on it (every
//! parallel pass adds its parts in a fixed order).

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Runs `op` on a thread of rayon's global pool (at once if the caller is a thread of a rayon
/// pool, this one or another: a sweep's trials stay on their pool's threads). A refinement runs
/// a few dozen short parallel passes; started from outside the pool, each would hand its
/// work to the pool and put the caller to sleep until it is done (two context switches per
/// pass), while from a pool thread the caller takes part in the pass. Unless another call
/// has one, a second pool thread is kept awake for the call: it runs the pool's pending
/// work and spins in between, for at most two seconds. Meant for calls of milliseconds to
/// seconds whose parallel work is in the global pool (identification, refinement, a bound,
/// a command of them); work in a pool of its own (a sweep) would leave the helper spinning
/// idle. The arithmetic is the same on any thread. `Identifier::identify`,
/// `Refiner::refine` and `Refiner::cramer_rao` use it. [`set_keep_awake`] turns the helper off.
pub fn on_pool<R: Send>(op: impl FnOnce() -> R + Send) -> R {
    if rayon::current_thread_index().is_some() {
        return op();
    }
    rayon::scope(|_| {
        let _awake = KeepAwake::start();
        op()
    })
}

/// Whether an [`on_pool`] call has a pool thread kept awake for it: one at a time, so that
/// two helpers can never wait on each other.
static KEPT_AWAKE: AtomicBool = AtomicBool::new(false);

/// Whether [`on_pool`] keeps a second pool thread awake for its calls ([`set_keep_awake`]).
static KEEP_AWAKE_ON: AtomicBool = AtomicBool::new(true);

/// Turns on or off, for the whole process, the second pool thread [`on_pool`] keeps awake
/// (spinning between pieces of work) while a call from outside rayon's pool runs; on by
/// default. Turn it off when the program's other threads need every core while they call the
/// library: the calls then take longer (the 10-hit refinement bench: 8.61 instead of 7.92 ms
/// on two threads), and give the same numbers.
pub fn set_keep_awake(on: bool) {
    KEEP_AWAKE_ON.store(on, Ordering::Relaxed);
}

/// Whether [`on_pool`] keeps a second pool thread awake for its calls ([`set_keep_awake`]).
pub fn keep_awake() -> bool {
    KEEP_AWAKE_ON.load(Ordering::Relaxed)
}

/// Longest time a helper of [`KeepAwake`] stays, whatever happens to its call: longer than
/// the calls it serves (a refinement of a 10-hit campaign takes 8 ms, `frameid identify` of
/// one 25 ms, a 10^6-sample identification 0.4 s), short enough that an unforeseen wait on
/// its call would be a stall rather than a hang.
const KEEP_AWAKE_MAX: Duration = Duration::from_secs(2);

/// Keeps a second pool thread awake while an [`on_pool`] call runs. An idle rayon thread
/// sleeps after about 32 rounds of `sched_yield` (tens of microseconds), and waking it took
/// about 0.2 ms on the 2-vCPU machine of the benchmarks: between the refinement's serial
/// steps and its passes (about 30 per refinement) the second thread joined each pass late
/// (pass 1 of the likelihood ran 1.26 times faster on two threads than on one, the
/// Jacobian pass 1.79 times). The helper is a job that runs the pool's pending work
/// (`rayon::yield_now`) and spins in between, until the call ends (the guard's drop, also
/// on unwinding) or [`KEEP_AWAKE_MAX`] has passed; on the call's own thread it returns at
/// once. Refinement bench, two threads, run alternately: 8.61 ms without, 7.92 ms with.
struct KeepAwake {
    done: Option<Arc<AtomicBool>>,
}

impl KeepAwake {
    fn start() -> Self {
        Self::start_if(keep_awake())
    }

    /// [`KeepAwake::start`] with the switch given (`on`).
    fn start_if(on: bool) -> Self {
        if !on || rayon::current_num_threads() < 2 || KEPT_AWAKE.swap(true, Ordering::AcqRel) {
            return Self { done: None };
        }
        let owner = rayon::current_thread_index();
        let done = Arc::new(AtomicBool::new(false));
        let flag = Arc::clone(&done);
        rayon::spawn(move || {
            if rayon::current_thread_index() == owner {
                return;
            }
            let start = Instant::now();
            while !flag.load(Ordering::Acquire) && start.elapsed() < KEEP_AWAKE_MAX {
                if rayon::yield_now() != Some(rayon::Yield::Executed) {
                    std::hint::spin_loop();
                }
            }
        });
        Self { done: Some(done) }
    }
}

impl Drop for KeepAwake {
    fn drop(&mut self) {
        if let Some(done) = &self.done {
            done.store(true, Ordering::Release);
            KEPT_AWAKE.store(false, Ordering::Release);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rayon::prelude::*;
    use std::panic::{AssertUnwindSafe, catch_unwind};

    /// Calls from several threads outside the pool at once, each with parallel work inside,
    /// all finish with the serial loop's sum (at most one has a helper, and no helper waits
    /// on another).
    #[test]
    fn concurrent_calls_from_outside_the_pool_finish() {
        let want: u64 = (0..20_000u64).map(|i| i * i % 7).sum();
        std::thread::scope(|s| {
            for _ in 0..4 {
                s.spawn(|| {
                    for _ in 0..50 {
                        let got = on_pool(|| {
                            (0..20_000u64)
                                .into_par_iter()
                                .map(|i| i * i % 7)
                                .sum::<u64>()
                        });
                        assert_eq!(got, want);
                    }
                });
            }
        });
    }

    /// A call that panics releases its helper: the guard's drop runs on unwinding. Other
    /// tests may hold the one helper at the time, so the call is retried until one gets it.
    #[test]
    fn a_panicking_call_releases_its_helper() {
        // A pool of two threads of its own: a helper needs a second thread, whatever the
        // machine's cores.
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let got_helper = (0..1000).any(|_| {
            let mut seen = None;
            let outcome = catch_unwind(AssertUnwindSafe(|| {
                pool.scope(|_| {
                    let awake = KeepAwake::start_if(true);
                    seen = awake.done.clone();
                    panic!("the call fails");
                })
            }));
            assert!(outcome.is_err(), "the panic reaches the caller");
            seen.inspect(|done| {
                assert!(done.load(Ordering::Acquire), "the helper was told to stop");
            })
            .is_some()
        });
        assert!(got_helper, "no call got the helper in 1000 tries");
    }

    /// Switched off, a call gets no helper, even when none is taken. (The test does not turn
    /// the process-wide switch off: other tests run beside it.)
    #[test]
    fn switched_off_no_helper_starts() {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        pool.install(|| {
            for _ in 0..100 {
                assert!(KeepAwake::start_if(false).done.is_none());
            }
        });
        set_keep_awake(true);
        assert!(keep_awake(), "on by default and when turned on");
    }
}
