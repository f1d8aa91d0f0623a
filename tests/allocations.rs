//! No allocation inside the step loop: heap allocations counted by a global allocator that
//! wraps the system one (its own test binary, so that the counter serves only these tests).
//!
//! Buffers that grow to a high-water mark are allowed; memory taken afresh every step is not.
//! So each scene is run for some steps, reset and run again: the replay needs exactly the
//! sizes the first run did, so with every buffer kept, it allocates nothing at all.
//!
//! When a test fails, `HAIR_TRACE_ALLOCATIONS=1 cargo test -p hair --test allocations --
//! --nocapture` prints where each allocation of the replay was made (the printing allocates
//! too, so the counts it reports are larger).

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering::Relaxed};

use hair::{LodPolicy, Scene, Simulation};

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);
static TRACING: AtomicBool = AtomicBool::new(false);

thread_local! {
    /// Set while this thread prints a trace, whose own allocations are not traced.
    static PRINTING: Cell<bool> = const { Cell::new(false) };
}

fn count(size: usize) {
    ALLOCATIONS.fetch_add(1, Relaxed);
    if TRACING.load(Relaxed) && !PRINTING.with(|p| p.replace(true)) {
        let trace = std::backtrace::Backtrace::force_capture().to_string();
        let ours: Vec<&str> = trace
            .lines()
            .filter(|l| l.contains("at ./") && !l.contains("tests/allocations.rs"))
            .take(4)
            .map(str::trim)
            .collect();
        eprintln!("allocation of {size} bytes {}", ours.join(" < "));
        PRINTING.with(|p| p.set(false));
    }
}

// SAFETY: every call is passed on to the system allocator unchanged; only a counter is added.
#[expect(
    unsafe_code,
    reason = "a counting global allocator must implement the unsafe GlobalAlloc trait"
)]
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count(layout.size());
        // SAFETY: the caller's contract is the system allocator's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count(layout.size());
        // SAFETY: as above.
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count(new_size);
        // SAFETY: as above.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: as above.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Runs `name` at `policy` for `steps` steps on a pool of two threads (the step is called from
/// inside the pool, as `hair run` does: called from outside, rayon takes a block for its queue
/// of outside jobs now and then), then resets it and replays the same steps three times;
/// returns each step's fewest allocations over the replays.
///
/// A worker grows its own lane buffers at the first group it takes. On a loaded machine the
/// other worker can take every group of the first run, and then that growth falls in the
/// first replay; an allocation made every step shows in every replay.
fn replayed_allocations(name: &str, policy: LodPolicy, steps: usize) -> Vec<usize> {
    let scene = Scene::load(name).expect("built-in scene");
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .expect("pool");
    pool.install(|| {
        let mut sim = Simulation::new(&scene, policy).expect("scene builds");
        let mut hashes = Vec::with_capacity(steps);
        for _ in 0..steps {
            sim.step().expect("step");
            hashes.push(sim.state_hash());
        }
        let trace = std::env::var_os("HAIR_TRACE_ALLOCATIONS").is_some();
        let mut fewest = vec![usize::MAX; steps];
        for _ in 0..3 {
            sim.reset();
            for (first, least) in hashes.iter().zip(&mut fewest) {
                let before = ALLOCATIONS.load(Relaxed);
                TRACING.store(trace, Relaxed);
                sim.step().expect("step");
                TRACING.store(false, Relaxed);
                *least = (*least).min(ALLOCATIONS.load(Relaxed) - before);
                // The replay must be the same run, or its sizes prove nothing.
                assert_eq!(sim.state_hash(), *first, "{name}: the replay differs");
            }
        }
        fewest
    })
}

/// One test for every scene, run one after another: the counter is global, so a scene run
/// beside another would count the other's allocations too.
#[test]
fn replayed_steps_allocate_nothing() {
    let runs = [
        ("wind", LodPolicy::Fine, 30),
        ("shake", LodPolicy::Fine, 30),
        ("torus", LodPolicy::Fine, 20),
        // LOD changes.
        ("zoom", LodPolicy::Adaptive, 40),
        // The salon tools, with the LOD changes they cause.
        ("salon", LodPolicy::Adaptive, 40),
        ("wardlin", LodPolicy::Fine, 8),
        ("shake", LodPolicy::Clusters, 20),
        ("wind", LodPolicy::Strips, 20),
    ];
    let mut failures = Vec::new();
    for (name, policy, steps) in runs {
        let counts = replayed_allocations(name, policy, steps);
        if counts.iter().any(|&c| c != 0) {
            failures.push(format!("{name} at {policy:?}: {counts:?}"));
        }
    }
    assert!(
        failures.is_empty(),
        "fewest allocations of each step over three replays:\n{}",
        failures.join("\n")
    );
}
