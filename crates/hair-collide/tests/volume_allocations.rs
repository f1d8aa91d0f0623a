//! The volume model takes no memory once its buffers have grown: a global allocator counts
//! every allocation of a replay (its own test binary, so the counter serves this test alone).

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};

use hair_collide::{HairVolume, VolumeSettings};
use hair_dynamics::{Material, Root, SkeletonDesc, SkeletonId, StrandState};
use hair_ssv::{Point, Real, Vector};
use nalgebra::Rotation3;

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

// SAFETY: every call is passed on to the system allocator unchanged; only a counter is added.
#[expect(
    unsafe_code,
    reason = "a counting global allocator must implement the unsafe GlobalAlloc trait"
)]
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Relaxed);
        // SAFETY: the caller's contract is the system allocator's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Relaxed);
        // SAFETY: as above.
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Relaxed);
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

/// A fan of strands swinging about their roots.
fn fan(count: usize) -> StrandState {
    let mut state = StrandState::new();
    for s in 0..count {
        let a = s as Real * 0.05;
        let root = Point::new(a.cos() * 0.05, 0.0, a.sin() * 0.05);
        let frame = Rotation3::new(Vector::new(0.3 * a.sin(), 0.0, 0.3 * a.cos()));
        let dir = frame * Vector::z();
        let points = (0..10).map(|k| root + dir * (0.01 * k as Real)).collect();
        state
            .add_skeleton(&SkeletonDesc {
                root: Root::Attached {
                    position: root,
                    frame,
                },
                points,
                material: Material::default(),
            })
            .expect("a valid strand");
        let id = SkeletonId(s as u32);
        for i in state.nodes(id).skip(1) {
            state.omega_theta_mut()[i] = 0.5 + a.sin();
        }
        state.refresh_positions(id);
    }
    state
}

#[test]
fn the_volume_response_allocates_nothing_once_grown() {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    pool.install(|| {
        let start = fan(400);
        let front: Vec<u32> = (0..400).collect();
        let settings = VolumeSettings::default();
        let mut state = start.clone();
        let mut volume = HairVolume::new();
        let run = |state: &mut StrandState, volume: &mut HairVolume| {
            for _ in 0..5 {
                volume
                    .respond(state, &front, &settings, 1.0 / 60.0)
                    .unwrap();
            }
        };
        run(&mut state, &mut volume);
        // The thread pool's own bookkeeping can take memory the first time a worker steals a
        // job (which a loaded machine may first make it do in a replay), so the replay runs
        // three times: an allocation of the volume's would show in every one.
        let taken: Vec<usize> = (0..3)
            .map(|_| {
                state.clone_from(&start);
                let before = ALLOCATIONS.load(Relaxed);
                run(&mut state, &mut volume);
                ALLOCATIONS.load(Relaxed) - before
            })
            .collect();
        assert!(
            taken.contains(&0),
            "every replay allocated (times per replay: {taken:?})"
        );
    });
}
