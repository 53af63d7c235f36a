//! The gateway's own tasks, counted for `drivebus_runtime_tasks`.
//!
//! The gateway runs its bus, MQTT, Sparkplug, page and fan-out tasks on a `LocalSet`
//! (`spawn_local`), and tokio counts only the tasks of the runtime itself
//! (`RuntimeMetrics::num_alive_tasks`): a leak of the gateway's own tasks would not show. Each of
//! them is started by [`spawn_local`], which counts it for as long as its future lives (to its
//! end, or until it is aborted or its `LocalSet` dropped) in the counter the thread was given
//! ([`count_on_this_thread`]: the one of the gateway's [`Metrics`](crate::metrics::Metrics)).

use std::cell::RefCell;
use std::future::Future;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use tokio::task::JoinHandle;

thread_local! {
    /// Where the tasks started on this thread are counted.
    static COUNT: RefCell<Option<Arc<AtomicUsize>>> = const { RefCell::new(None) };
}

/// Count the tasks [`spawn_local`] starts on this thread (the gateway's) in `count`.
pub fn count_on_this_thread(count: Arc<AtomicUsize>) {
    COUNT.with(|c| *c.borrow_mut() = Some(count));
}

/// One task alive.
struct Alive(Arc<AtomicUsize>);

impl Alive {
    fn new(count: Arc<AtomicUsize>) -> Alive {
        count.fetch_add(1, Ordering::Relaxed);
        Alive(count)
    }
}

impl Drop for Alive {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::Relaxed);
    }
}

/// `tokio::task::spawn_local`, the task counted while its future lives.
pub fn spawn_local<F>(future: F) -> JoinHandle<F::Output>
where
    F: Future + 'static,
    F::Output: 'static,
{
    let alive = COUNT.with(|c| c.borrow().clone()).map(Alive::new);
    tokio::task::spawn_local(async move {
        let _alive = alive;
        future.await
    })
}
