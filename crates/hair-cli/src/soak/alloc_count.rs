//! The binary's counting allocator: it counts heap allocations only while a soak asks, so every
//! other command pays one relaxed load per allocation and nothing else.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering::Relaxed};

// relaxed load per allocation and nothing else.

struct CountingAllocator;

static COUNTING: AtomicBool = AtomicBool::new(false);
static ALLOCATIONS: AtomicU64 = AtomicU64::new(0);

/// Set by `HAIR_TRACE_ALLOCATIONS`: each allocation of a replayed step prints where it was made
/// (the printing allocates too: the counts are then larger).
static TRACING: AtomicBool = AtomicBool::new(false);

thread_local! {
    /// Set while this thread prints a trace, whose own allocations are not traced.
    static PRINTING: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

fn note_allocation() {
    if COUNTING.load(Relaxed) {
        ALLOCATIONS.fetch_add(1, Relaxed);
        if TRACING.load(Relaxed) && !PRINTING.with(|p| p.replace(true)) {
            let trace = std::backtrace::Backtrace::force_capture().to_string();
            let ours = trace
                .lines()
                .filter(|l| l.contains("at ./") && !l.contains("soak.rs"));
            let ours: Vec<&str> = ours.take(5).map(str::trim).collect();
            eprintln!("allocation in a step: {}", ours.join(" < "));
            PRINTING.with(|p| p.set(false));
        }
    }
}

// SAFETY: every call is passed to the system allocator unchanged; only a counter is added.
#[expect(
    unsafe_code,
    reason = "a counting global allocator must implement the unsafe GlobalAlloc trait"
)]
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note_allocation();
        // SAFETY: the caller's contract is the system allocator's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note_allocation();
        // SAFETY: as above.
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note_allocation();
        // SAFETY: as above.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: as above.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

/// Runs `f` and returns its result with the allocations made meanwhile (on every thread).
pub(super) fn counting_allocations<T>(f: impl FnOnce() -> T) -> (T, u64) {
    let before = ALLOCATIONS.load(Relaxed);
    COUNTING.store(true, Relaxed);
    let out = f();
    COUNTING.store(false, Relaxed);
    (out, ALLOCATIONS.load(Relaxed) - before)
}

/// [`counting_allocations`] with tracing held off (the live pass's growth is allowed).
pub(super) fn counting_allocations_untraced<T>(f: impl FnOnce() -> T) -> (T, u64) {
    let tracing = TRACING.swap(false, Relaxed);
    let out = counting_allocations(f);
    TRACING.store(tracing, Relaxed);
    out
}

/// Traces the allocations of counted steps when `HAIR_TRACE_ALLOCATIONS` is set.
pub(super) fn trace_from_env() {
    let on = std::env::var_os("HAIR_TRACE_ALLOCATIONS").is_some();
    TRACING.store(on, Relaxed);
}
