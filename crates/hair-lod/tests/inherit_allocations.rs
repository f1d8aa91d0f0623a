//! `inherit_edits` takes no memory once its scratch and output have grown: heap allocations on
//! the calling thread counted by a global allocator that wraps the system one (its own test
//! binary, so that the counter serves only this test). A capacity check alone would miss a
//! list dropped and grown again to the same size.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use hair_lod::*;

struct Counting;

thread_local! {
    /// Allocations made by this thread.
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

fn count() {
    // A thread being torn down has no counter left; its allocations are not this test's.
    let _ = ALLOCATIONS.try_with(|a| a.set(a.get() + 1));
}

// SAFETY: every call is passed on to the system allocator unchanged; only a counter is added.
#[expect(
    unsafe_code,
    reason = "a counting global allocator must implement the unsafe GlobalAlloc trait"
)]
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        // SAFETY: the caller's contract is the system allocator's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count();
        // SAFETY: as above.
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
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

fn allocations() -> usize {
    ALLOCATIONS.with(Cell::get)
}

#[test]
fn inherit_edits_allocates_nothing_once_grown() {
    let h = Hierarchy::build(
        &test_heads::ward_lin_head(400, 6),
        &HierarchyParams::default(),
    )
    .expect("valid head");
    let mut state = LodState::new(&h);
    let mut rng = test_heads::SplitMix64::new(6);
    let edits: Vec<Vec<u32>> = (0..20)
        .map(|_| {
            (0..1 + rng.next_u64() % 30)
                .map(|_| (rng.next_u64() % h.node_count() as u64) as u32)
                .collect()
        })
        .collect();
    let (mut scratch, mut changed) = (InheritScratch::default(), Vec::new());
    let full = |n| h.control_point_range(n);
    // Grow the lists to every edit's needs, then replay the edits.
    for round in 0..2 {
        let before = allocations();
        for touched in &edits {
            for (i, &t) in touched.iter().enumerate() {
                state.wetness[h.control_point_start(t) + i % 3] += 0.1;
            }
            inherit_edits(
                &h,
                touched,
                full,
                &mut [&mut state.wetness[..], &mut state.stiffness[..]],
                &mut scratch,
                &mut changed,
            )
            .expect("valid edit");
        }
        let made = allocations() - before;
        if round == 0 {
            assert!(made > 0, "the counter sees the first round grow the lists");
        } else {
            assert_eq!(made, 0, "allocations in the replay");
        }
    }
}
