//! Dedicated render threads. The builtin renderer computes on the thread that calls it (a few
//! milliseconds of tessellation, rasterisation on a CPU driver, readback, PNG encoding); called
//! from an async task it would hold a tokio worker the whole time, and at high concurrency on a
//! small machine the model calls' HTTP would stall behind it. [`RenderPool`] runs such a
//! renderer on named threads (`revelio-render-N`, shared by every pool of the process and kept
//! until it exits) behind a bounded queue of its own: an observation waits for a queue slot
//! asynchronously, never blocking a worker.
use std::future::Future;
use std::sync::mpsc::{Sender, channel};
use std::sync::{Arc, OnceLock};
use std::task::{Context, Poll, Wake, Waker};

use tokio::sync::Semaphore;

use crate::net::BoxFuture;
use crate::render::{RenderError, Rendered, Renderer};
use crate::scene::Scene;

type Job = Box<dyn FnOnce() + Send>;

/// A blocking renderer on dedicated threads, itself a non-blocking [`Renderer`].
pub struct RenderPool {
    inner: Arc<dyn Renderer>,
    jobs: &'static Sender<Job>,
    /// Queue slots: renders in progress or waiting for a thread. Several threads let one
    /// frame's tessellation and encoding overlap another's rasterisation (`benches/render.rs`).
    slots: Semaphore,
}

/// Render threads: the cores, at most 4 (the builtin renderer's throughput stops growing there).
pub fn render_threads() -> usize {
    std::thread::available_parallelism().map_or(2, |n| n.get()).clamp(1, 4)
}

/// The queue of the render threads, started on first use and shared by every pool: they live
/// as long as the process and never exit. A thread that draws through EGL holds per-thread
/// driver state whose destructor (libglvnd's, run when the thread exits) can race the
/// library's own teardown at process exit and abort it with "double free or corruption": pool
/// threads that ended when their pool was dropped, just before `main` returned, did so once at
/// the end of a `revelio ask`. A thread still waiting for a job at exit runs no destructor.
fn shared_jobs() -> &'static Sender<Job> {
    static JOBS: OnceLock<Sender<Job>> = OnceLock::new();
    JOBS.get_or_init(|| {
        let (jobs, rx) = channel::<Job>();
        let rx = Arc::new(std::sync::Mutex::new(rx));
        for i in 0..render_threads() {
            let rx = rx.clone();
            let spawned = std::thread::Builder::new().name(format!("revelio-render-{i}")).spawn(move || {
                loop {
                    // The lock is held only while taking a job, never while rendering.
                    let job = match rx.lock().unwrap_or_else(|p| p.into_inner()).recv() {
                        Ok(job) => job,
                        Err(_) => break,
                    };
                    job();
                }
            });
            // Without any thread every render fails with a clear error below instead.
            drop(spawned);
        }
        jobs
    })
}

impl RenderPool {
    /// `inner` on the shared render threads ([`render_threads`] of them).
    pub fn wrap(inner: Arc<dyn Renderer>) -> Arc<dyn Renderer> {
        Arc::new(RenderPool::new(inner))
    }

    /// `inner` on the shared render threads, with a queue of twice as many renders as threads.
    pub fn new(inner: Arc<dyn Renderer>) -> RenderPool {
        RenderPool { inner, jobs: shared_jobs(), slots: Semaphore::new(2 * render_threads()) }
    }
}

impl Renderer for RenderPool {
    fn id(&self) -> String {
        self.inner.id()
    }

    fn render<'a>(&'a self, scene: &'a Scene, prompt: &'a str) -> BoxFuture<'a, Result<Rendered, RenderError>> {
        Box::pin(async move {
            let _slot =
                self.slots.acquire().await.map_err(|_| RenderError::new("the render queue was closed".to_string()))?;
            let (tx, rx) = tokio::sync::oneshot::channel();
            let (inner, scene, prompt) = (self.inner.clone(), scene.clone(), prompt.to_string());
            let job: Job = Box::new(move || {
                let drawn =
                    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| block_on(inner.render(&scene, &prompt))))
                        .unwrap_or_else(|_| {
                            Err(RenderError::new("the renderer panicked while drawing this scene".to_string()))
                        });
                let _ = tx.send(drawn);
            });
            self.jobs.send(job).map_err(|_| RenderError::new("the render threads could not be started".to_string()))?;
            rx.await.unwrap_or_else(|_| Err(RenderError::new("the render threads could not be started".to_string())))
        })
    }
}

/// Drive a future to completion on the current (render) thread.
fn block_on<F: Future>(f: F) -> F::Output {
    struct Unpark(std::thread::Thread);
    impl Wake for Unpark {
        fn wake(self: Arc<Self>) {
            self.0.unpark();
        }
    }
    let waker = Waker::from(Arc::new(Unpark(std::thread::current())));
    let mut cx = Context::from_waker(&waker);
    let mut f = std::pin::pin!(f);
    loop {
        if let Poll::Ready(v) = f.as_mut().poll(&mut cx) {
            return v;
        }
        std::thread::park();
    }
}
