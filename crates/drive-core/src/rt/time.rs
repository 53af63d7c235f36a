//! Time of the runtime layer: tokio's clock and timers, or a [`VirtualClock`]'s.
//!
//! Every timer of the drivers, serve loops and simulated links goes through [`now`],
//! [`sleep_until`], [`sleep`], [`timeout`] and [`interval`]. Outside a [`VirtualClock`] they
//! are tokio's (real, or paused in tests); one relaxed atomic load decides. Inside
//! [`VirtualClock::run`] time stands still while any task can run and jumps to the earliest
//! deadline when every task is idle: tokio's paused clock and its auto-advance, without
//! tokio's `test-util`.
//!
//! The virtual timers tick as tokio's do ([`TIMER_RESOLUTION`]): a wait ends on the first tick
//! at or after its deadline, ticks counted from the clock's start, and a jump moves the clock
//! by whole ticks (see [`VirtualClock`] for the phase of a session within its first tick).

use core::cell::RefCell;
use core::future::{Future, poll_fn};
use core::pin::{Pin, pin};
use core::task::{Context, Poll, Waker};
use core::time::Duration;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::task::Wake;

pub use tokio::time::{Instant, MissedTickBehavior};

use super::io::TIMER_RESOLUTION;

/// How many virtual clocks run (on any thread): zero, tokio's clock without a thread-local
/// look-up.
static RUNNING: AtomicUsize = AtomicUsize::new(0);

std::thread_local! {
    static CURRENT: RefCell<Option<Arc<State>>> = const { RefCell::new(None) };
}

/// The virtual clock running on this thread, if any.
#[inline]
fn current() -> Option<Arc<State>> {
    if RUNNING.load(Ordering::Relaxed) == 0 {
        return None;
    }
    CURRENT.try_with(|c| c.borrow().clone()).ok().flatten()
}

/// A timer tick count from `start`, rounded down.
fn tick_of(d: Duration) -> u64 {
    let t = d.as_nanos() / TIMER_RESOLUTION.as_nanos();
    u64::try_from(t).unwrap_or(u64::MAX)
}

#[derive(Debug)]
struct Timer {
    id: u64,
    tick: u64,
    waker: Waker,
}

/// The state of one virtual clock (only ever used on its runtime's thread).
#[derive(Debug)]
struct State {
    start: Instant,
    inner: std::sync::Mutex<Inner>,
    /// The session's future was woken: some work is left, the clock must not jump.
    main_woken: AtomicBool,
}

#[derive(Debug, Default)]
struct Inner {
    /// Since `start`.
    elapsed: Duration,
    timers: Vec<Timer>,
    next_id: u64,
}

impl State {
    fn inner(&self) -> std::sync::MutexGuard<'_, Inner> {
        self.inner
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    fn now(&self) -> Instant {
        let inner = self.inner();
        self.start + inner.elapsed
    }

    /// The tick at which a timer for `deadline` ends (tokio: rounded up to a whole tick).
    fn deadline_tick(&self, deadline: Instant) -> u64 {
        let d = deadline.saturating_duration_since(self.start);
        tick_of(d.saturating_add(TIMER_RESOLUTION - Duration::from_nanos(1)))
    }

    /// Polls the timer `id` (0: not registered yet) for `deadline`.
    fn poll_timer(&self, id: &mut u64, deadline: Instant, cx: &Context<'_>) -> Poll<()> {
        let tick = self.deadline_tick(deadline);
        let mut inner = self.inner();
        let now_tick = tick_of(inner.elapsed);
        if tick <= now_tick {
            let gone = *id;
            inner.timers.retain(|t| t.id != gone);
            *id = 0;
            return Poll::Ready(());
        }
        if let Some(t) = inner.timers.iter_mut().find(|t| t.id == *id && *id != 0) {
            t.tick = tick;
            t.waker.clone_from(cx.waker());
        } else {
            inner.next_id += 1;
            *id = inner.next_id;
            let timer = Timer {
                id: *id,
                tick,
                waker: cx.waker().clone(),
            };
            inner.timers.push(timer);
        }
        Poll::Pending
    }

    fn cancel(&self, id: u64) {
        if id != 0 {
            self.inner().timers.retain(|t| t.id != id);
        }
    }

    /// Every task is idle: the clock jumps by whole ticks to the earliest deadline and wakes
    /// the timers that ended.
    fn park(&self) {
        if self.main_woken.load(Ordering::SeqCst) {
            return;
        }
        let woken: Vec<Waker> = {
            let mut inner = self.inner();
            let Some(next) = inner.timers.iter().map(|t| t.tick).min() else {
                return;
            };
            let now = inner.elapsed;
            let now_tick = tick_of(now);
            let jump = TIMER_RESOLUTION
                .saturating_mul(u32::try_from(next.saturating_sub(now_tick)).unwrap_or(u32::MAX));
            let now = now.saturating_add(jump);
            inner.elapsed = now;
            let now_tick = tick_of(now);
            let (ended, left): (Vec<Timer>, Vec<Timer>) =
                inner.timers.drain(..).partition(|t| t.tick <= now_tick);
            inner.timers = left;
            ended.into_iter().map(|t| t.waker).collect()
        };
        for w in woken {
            w.wake();
        }
    }
}

/// Now: tokio's clock, or the virtual clock this thread runs.
#[inline]
pub fn now() -> Instant {
    match current() {
        None => Instant::now(),
        Some(s) => s.now(),
    }
}

/// The time since `earlier` on the same clock as [`now`] (zero if `earlier` is later).
#[inline]
pub fn elapsed(earlier: Instant) -> Duration {
    now().saturating_duration_since(earlier)
}

/// A timer that ends at a deadline: tokio's [`tokio::time::Sleep`] or a virtual clock's.
#[derive(Debug)]
pub struct Sleep {
    deadline: Instant,
    kind: Kind,
}

#[derive(Debug)]
enum Kind {
    Tokio(Pin<Box<tokio::time::Sleep>>),
    Virtual(u64),
}

/// A [`Sleep`] until `deadline`.
#[inline]
pub fn sleep_until(deadline: Instant) -> Sleep {
    let kind = if current().is_some() {
        Kind::Virtual(0)
    } else {
        Kind::Tokio(Box::pin(tokio::time::sleep_until(deadline)))
    };
    Sleep { deadline, kind }
}

/// A [`Sleep`] of `duration` from now.
pub fn sleep(duration: Duration) -> Sleep {
    let now = now();
    sleep_until(
        now.checked_add(duration)
            .unwrap_or(now + Duration::from_secs(86_400 * 365)),
    )
}

impl Sleep {
    /// Its deadline.
    pub fn deadline(&self) -> Instant {
        self.deadline
    }

    /// The timer ends at `deadline` instead.
    pub fn reset(self: Pin<&mut Self>, deadline: Instant) {
        let this = self.get_mut();
        this.deadline = deadline;
        if let Kind::Tokio(s) = &mut this.kind {
            s.as_mut().reset(deadline);
        }
    }
}

impl Future for Sleep {
    type Output = ();

    fn poll(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<()> {
        let this = self.get_mut();
        match &mut this.kind {
            Kind::Tokio(s) => s.as_mut().poll(cx),
            Kind::Virtual(id) => match current() {
                Some(s) => s.poll_timer(id, this.deadline, cx),
                // Its clock is gone: nothing will ever advance it.
                None => Poll::Pending,
            },
        }
    }
}

impl Drop for Sleep {
    fn drop(&mut self) {
        if let Kind::Virtual(id) = self.kind
            && id != 0
            && let Some(s) = current()
        {
            s.cancel(id);
        }
    }
}

/// The time given to [`timeout`] ran out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Elapsed;

/// `future`, unless `duration` ends first (as [`tokio::time::timeout`]: the future is polled
/// first).
pub async fn timeout<F: Future>(duration: Duration, future: F) -> Result<F::Output, Elapsed> {
    let mut future = pin!(future);
    let mut delay = sleep(duration);
    poll_fn(|cx| {
        if let Poll::Ready(v) = future.as_mut().poll(cx) {
            return Poll::Ready(Ok(v));
        }
        Pin::new(&mut delay).poll(cx).map(|()| Err(Elapsed))
    })
    .await
}

/// A steady rhythm, as [`tokio::time::Interval`]: the first tick ends at once.
#[derive(Debug)]
pub struct Interval {
    delay: Sleep,
    period: Duration,
    missed: MissedTickBehavior,
}

/// An [`Interval`] of `period` whose first tick is now.
pub fn interval(period: Duration) -> Interval {
    Interval {
        delay: sleep_until(now()),
        period,
        missed: MissedTickBehavior::Burst,
    }
}

impl Interval {
    /// What a late tick does.
    pub fn set_missed_tick_behavior(&mut self, behavior: MissedTickBehavior) {
        self.missed = behavior;
    }

    /// Waits for the next tick and returns its time.
    pub async fn tick(&mut self) -> Instant {
        poll_fn(|cx| self.poll_tick(cx)).await
    }

    fn poll_tick(&mut self, cx: &mut Context<'_>) -> Poll<Instant> {
        if Pin::new(&mut self.delay).poll(cx).is_pending() {
            return Poll::Pending;
        }
        let timeout = self.delay.deadline();
        let now = now();
        let next = if now > timeout + Duration::from_millis(5) {
            match self.missed {
                MissedTickBehavior::Burst => timeout + self.period,
                MissedTickBehavior::Delay => now + self.period,
                _ => {
                    let late = (now - timeout).as_nanos() % self.period.as_nanos().max(1);
                    let late = Duration::from_nanos(u64::try_from(late).unwrap_or(0));
                    now + self.period.saturating_sub(late)
                }
            }
        } else {
            timeout + self.period
        };
        Pin::new(&mut self.delay).reset(next);
        Poll::Ready(timeout)
    }
}

/// A virtual clock: [`VirtualClock::run`] runs a future on a current-thread runtime of its
/// own whose time stands still while any task can run and jumps to the earliest deadline when
/// every task is idle. Simulated wire time is counted, not waited.
///
/// Ticks count from the clock's start; the session begins `phase` after it (less than a tick).
/// On tokio's paused clock that phase is the real time from the runtime's start to
/// `tokio::time::pause()` (tens of µs, different on every run), and the figures of a session
/// whose waits are not whole ticks depend on it; here it is fixed, so they are the same on
/// every run.
#[derive(Debug, Default, Clone, Copy)]
pub struct VirtualClock {
    phase: Duration,
}

/// The phase of a session on tokio's paused clock started by `tokio::time::pause()` right
/// after the runtime's build (what `drivectl` did before its runs had a clock of their own):
/// the figures of its simulated sessions are the ones it printed on most runs.
pub const PAUSE_PHASE: Duration = Duration::from_micros(50);

/// The waker of the session's future: it notes that the session has work left.
struct MainWaker {
    state: Arc<State>,
    inner: Waker,
}

impl Wake for MainWaker {
    fn wake(self: Arc<Self>) {
        self.wake_by_ref();
    }

    fn wake_by_ref(self: &Arc<Self>) {
        self.state.main_woken.store(true, Ordering::SeqCst);
        self.inner.wake_by_ref();
    }
}

impl VirtualClock {
    /// A clock whose session begins on its first tick (as on a runtime started paused).
    pub const fn new() -> Self {
        Self {
            phase: Duration::ZERO,
        }
    }

    /// A clock whose session begins `phase` after a tick (at most one tick less a nanosecond).
    pub fn with_phase(phase: Duration) -> Self {
        Self {
            phase: phase.min(TIMER_RESOLUTION - Duration::from_nanos(1)),
        }
    }

    /// Runs `future` to its end on the virtual clock.
    ///
    /// # Errors
    ///
    /// The runtime could not be built.
    pub fn run<F: Future>(self, future: F) -> std::io::Result<F::Output> {
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .on_thread_park(|| {
                if let Some(s) = current() {
                    s.park();
                }
            })
            .build()?;
        let state = Arc::new(State {
            start: Instant::now(),
            inner: std::sync::Mutex::new(Inner {
                elapsed: self.phase,
                timers: Vec::new(),
                next_id: 0,
            }),
            main_woken: AtomicBool::new(false),
        });
        let previous = CURRENT.with(|c| c.borrow_mut().replace(Arc::clone(&state)));
        RUNNING.fetch_add(1, Ordering::SeqCst);
        let _restore = Restore(previous);
        let mut future = pin!(future);
        Ok(rt.block_on(poll_fn(|cx| {
            state.main_woken.store(false, Ordering::SeqCst);
            let waker = Waker::from(Arc::new(MainWaker {
                state: Arc::clone(&state),
                inner: cx.waker().clone(),
            }));
            let mut cx = Context::from_waker(&waker);
            future.as_mut().poll(&mut cx)
        })))
    }
}

/// Puts back the thread's previous clock when a run ends (or unwinds).
struct Restore(Option<Arc<State>>);

impl Drop for Restore {
    fn drop(&mut self) {
        let previous = self.0.take();
        let _ = CURRENT.try_with(|c| *c.borrow_mut() = previous);
        RUNNING.fetch_sub(1, Ordering::SeqCst);
    }
}
