//! `hair-grid`: the localization grid of the hair simulation (Ward & Lin 2003 §5.3; Ward,
//! Galoppo & Lin, *Interactive Virtual Hair Salon*, §4.3-4.4).
//!
//! A sparse uniform grid, rebuilt every step in O(n) and in parallel, that finds hair-hair pairs,
//! the cells where hair meets the body, the sections a salon tool acts on, and the cells that can
//! stop being simulated.
//!
//! | item | what it offers |
//! |---|---|
//! | [`Grid`], [`GridConfig`], [`Section`] | insert hair sections (LSS / RSS / PSS from `hair-ssv`); cell size = mean segment length by default; each section covers exactly the cells its core reaches, grown by its radius |
//! | [`Grid::candidate_pairs`], [`Grid::overlapping_pairs`], [`PairSet`] | unique hair-hair candidate pairs (each reported once, optionally skipping same-skeleton neighbours), and the exact-overlap pairs by `hair-ssv` distance |
//! | [`Grid::overlapping_pairs_by_rank`], [`Grid::search_order`] | the same pairs by position in the search's order, for callers that lay their per-section data out in it |
//! | [`kernel_name`] | which instruction set the search runs here (AVX-512, AVX2 or baseline: the same results, different times) |
//! | [`BodyGrid`], [`Grid::body_cells`], [`BodyCells`] | body triangles inserted once; cells holding both hair and body, with their triangles |
//! | [`InfluenceVolume`], [`Cone`], [`Grid::sections_in`], [`Grid::cells_touched_by`] | tool volumes (cone for water, spray, mousse, dryer, grab; triangle for scissors): cells first, then the exact test |
//! | [`Activity`], [`ActivityConfig`], [`ActivityInput`], [`CellState`] | active and dormant cells; frozen sections; the skeletons to integrate this step |
//! | [`CellKey`] | integer cell coordinates on the global lattice, packed into ordered `u64` keys |
//! | [`GridError`] | every failure on untrusted input (non-finite coordinates, bad cell size, too many cells) |
//! | [`test_scenes`] | the seeded head-sized shell of hair that `hair bench grid`, the criterion benches and `examples/grid_profile.rs` measure |
//!
//! ## How the pair search works, and what it costs
//!
//! Cells are `h` = the mean segment length by default ([`GridConfig::cell_size`] overrides it).
//! A rebuild validates and covers every section in parallel chunks of 1024 (each cover is the
//! exact set of cells its core reaches, grown by its radius, not the bounding box: a slab walk,
//! or for a segment whose cell range is small, at most 4 x 4 x 4 and 32 cells, a test of each
//! cell of that range, which gives the same cells), sorts the (cell, section) entries by a
//! parallel counting sort over the box of the covers (each entry's index in that box is
//! computed once, then reused by the scatter), then
//! copies the data the pair search needs into its own order, sections sorted by their first cell
//! (a second counting sort, done before the scatter so that the entries are renumbered as they
//! are copied out of it). That copy is what makes the search fast: walking the cells in key
//! order then reads a sliding window of nearby memory instead of one cache miss per entry, as the
//! caller's strand order would give.
//!
//! Per cell, the search gathers the boxes into columns and tests each row of pairs eight boxes
//! per instruction with AVX2 (detected at run time; the whole task is then compiled for it) or
//! four with SSE2 (part of every x86-64), giving a word of hit bits per 64 boxes (plain Rust on
//! other processors); a box hit on the same skeleton within `skip_neighbours` is dropped;
//! otherwise it is reported only by the first cell (in key order) both sections cover. The
//! rebuild stores with each entry its section's earlier cells, as a bit set of the 5 x 5 x 5
//! window around the cell, so that this test is one AND of two words read in cell order (no key
//! lists, no hash set; the key lists decide only when a cover leaves the window), computed
//! without a branch (its outcome is unpredictable);
//! the survivors get the exact LSS-LSS distance eight at a time, and any pair within a rounding
//! band of the margin (or not two LSS) goes to the scalar `hair-ssv` kernel, so the set is
//! exactly `Ssv::distance <= margin`. Cells are split into tasks of about equal estimated work
//! (`m^2` pair tests for a cell of `m` sections; fixed counts of 256 cells left a simulation's
//! few crowded cells of long sections to one thread), and the output is their concatenation in
//! order, so it does not depend on the number of threads or on the kernel (a test runs both).
//!
//! Measured on the `hair bench grid` scene (300,000 segments of about 1 cm, radius 0.5 mm, on a
//! head-sized shell; 865,502 entries, 1.2 M candidates, 199,478 overlapping pairs), one thread,
//! CPU time on a shared 2-core machine (load about 5): the pair search went from 360 ms to
//! 165 ms (0.93 G to 0.68 G instructions: most of the gain is fewer cache misses), the rebuild
//! from 82 ms to 105 ms (the copy into the search order). With 2 threads, `hair bench grid`
//! now runs 1.6 times faster than the parry3d BVH peer measured in the same run (1.16 before).
//! Where the time goes: 15.5 M in-cell box tests at the default cell size, 2.6 M box hits through
//! the neighbour and owner tests, 1.3 M exact tests, and in the rebuild the cover walk and the
//! two counting sorts. The earlier-cell bit sets and the branch-free scan of the box hits then
//! cut the pair search by about 15% in `cargo run --release -- bench grid --json` (`pairs_ms`,
//! old and new measured alternately on the same machine), mostly through fewer mispredicted
//! branches, and made the rebuild a little slower (the bit sets are computed and sorted with the
//! entries). Smaller or larger cells (0.5 to 1.3 cm) barely change `candidates` (the box
//! overlaps bound them), and copying each section's box and core next to every entry, so that
//! the search reads cells contiguously, costs more in the sort than it saves.
//!
//! The rebuild then went from 546 M to 455 M instructions (one thread, `examples/grid_profile.rs`
//! under callgrind; the pair search stays at 662 M) with the same cells, entries and pairs in
//! the same order: short segments are covered by testing each cell of their small cell range
//! (the covers of the scene's segments are 2.9 cells on average) instead of the general walk,
//! their earlier-cell bit sets come from the cell coordinates, each entry's dense cell index is
//! computed once, the entry buffers are no longer zeroed at each rebuild, the scatter writes an
//! entry's section and bit set side by side, and each section's record (box, ids and exact-test
//! core) fills one cache line, read once when copying into the search order. In
//! `cargo run --release -- bench grid --json`, run alternately with the previous build on the
//! shared 2-core machine (load about 4), `build_ms` went from 86-104 ms to 63-95 ms and
//! `pairs_ms` did not change.
//!
//! The rebuild then went from 496 M to 260 M instructions (one thread, `grid_profile` under
//! callgrind, half the difference of `build 3` and `build 1`; 496 M is the previous build
//! measured the same way on this machine, the 455 M above an earlier measurement), with the
//! same cells, entries and pairs in the same order (the three `grid_profile` hashes). A valid
//! LSS whose cell range is short is covered as a bit mask of that range, not a list of cells:
//! it is validated by one range test of its grown ends in cells (a NaN or infinite value, or a
//! cell outside the lattice, fails it), floored without the saturating conversion, only the
//! slab bounds between two cells of the range are computed (the outer bounds of the first and
//! last cells lie beyond the segment's ends by at least `2 r / |d|` and clamp to exactly 0 and
//! 1), a range of at most 2 cells per axis (most of them) is tested unrolled with its intervals
//! in registers, and the keys and earlier-cell bit sets come from tables (by the cover's byte
//! for a 2 x 2 x 2 range, else by the offset between two cells); every other section, and every
//! error, takes the general path as before. The mean cell size is summed per chunk and rounded
//! without the libm call (later in floats per chunk, rounded once per chunk instead of once per
//! section: 277.0 M to 271.3 M instructions per rebuild, fastest of `grid_profile build 20`
//! 13.2-13.6 to 12.9-13.0 ms). The count pass also reads each section's first cell, the prefix over
//! the box lists the non-empty cells in the same walk, and the pair search's order is computed
//! before the scatter, whose two-word slots carry each entry's section and rank (looked up once
//! per section), so that the copy out of it also renumbers the entries (no separate pass).
//! `grid_profile build 10` (min / median of the ten rebuilds), run alternately with the
//! previous build on the shared 2-core machine (load average 1.5-1.8, from another engineer's
//! builds that came and went): with 2 threads, min 29.2-30.3 ms before and 21.1-23.3 ms after
//! (medians 29.9-33.3 and 21.4-28.8 ms); with one thread (`RAYON_NUM_THREADS=1`), min
//! 55.9-59.8 ms before and 40.2-44.7 ms after, and CPU time per rebuild (`perf stat -e
//! task-clock`, `build 21` minus `build 1`) 56-72 ms before and 43-44 ms after (across runs
//! under that changing load).
//! The wall time falls less than the instructions: the scatter of the entries and the
//! gather into the search order (random accesses over 14 and 19 MB) and the sequential ranking
//! of the sections now take about a third of it on one thread.
//!
//! The pair search then went from 657 M to 430 M instructions (one thread, `grid_profile pairs`,
//! half the difference of 1 and 3 repeats under callgrind) and from 75 ms to 49 ms on one thread
//! (fastest of 10, `RAYON_NUM_THREADS=1 grid_profile pairs 10`, with a build running on the other
//! core), pairs identical and in the same order. The steps: box rows by SSE2 compares and
//! `movemask` instead of bytes gathered into bits (657 M to 515 M), by AVX2 (438 M once the whole
//! task is compiled for it: a call per row cost more than the row), and the owner test as bit
//! arithmetic (a branch on it was mispredicted about every other hit: 57 ms to 49 ms, instructions
//! unchanged). Of the 430 M, about 365 M find the candidates (`grid_profile candidates`) and 65 M
//! are the exact test.
//! Measured and dropped: a two-pass radix sort instead of the single counting scatter (more
//! instructions and more simulated cache misses, no faster), a line-line distance bound before the
//! exact test (hair is close to parallel, so it rejects too few candidates to pay for itself),
//! and testing rows of boxes in groups of four instead of eight (more instructions); with AVX2,
//! running the neighbour and owner tests lane-wise on every group of eight holding a box hit
//! (505 M instead of 436 M instructions), testing eight later sections against each earlier one
//! in turn instead of rows (1.6 times slower: a branch per group of eight on whether any box hit
//! is taken about as often as not), and smaller cells (0.5 to 0.8 cm: fewer box tests, but
//! both the rebuild and the search slower); in the rebuild, appending a 2 x 2 x 2 cover's keys
//! from a table of its cells with exact-size iterators (16 M more instructions than a loop over
//! its bits), keeping each chunk's box in locals (more spills, 2.5 M more), and ranking the
//! sections in parallel blocks (2 M more, and with 2 threads about 1 ms slower: the order then
//! goes through a shared buffer).
//!
//! With both, on the 2-core machine with nothing else running (load average below 0.5):
//! `grid_profile both 10` gives a rebuild in 22-26 ms and a pair search in 24-25 ms (fastest of
//! ten, 2 threads); `cargo run --release -- bench grid --json` (medians of seven) gives
//! `build_ms` 27-31, `pairs_ms` 26-32, `total_ms` 53-64 and `ratio` 5.2-6.4 against the parry3d
//! BVH (314-340 ms), where the same run before these changes gave 31 + 39 = 70 ms and 4.2-4.6.
//! (The AVX-512 kernels below then brought it under 30 ms while the host runs at its usual speed.)
//!
//! Then, for crowded cells of long sections (a simulation's: `wardlin` at its finest level has
//! 18,220 sections of 5 cm in 248 cells of about 215), three changes with the same pairs in the
//! same order (the three `grid_profile` hashes, on the bench scene and on a dump of `wardlin`'s
//! sections). First, the AVX2 row kernel also drops the box hits whose two sections share an
//! earlier cell inside the window (one AND and compare of the bit sets per four lanes; a hit it
//! keeps still goes through the full owner test): there, most box hits are the same pair met again
//! in its second or third shared cell, and 39% of the hits (3.4 M to 2.05 M per search, 2.04 M of
//! them candidates) no longer reach the scalar loop; on the bench scene too (2.4 M to 1.5 M). (The
//! whole owner and neighbour test lane-wise, measured before, cost more than it saved; this
//! cut-down one does not.) Second, the exact test reads each candidate's core as one register (a
//! core is eight floats), transposes eight of them in registers, and takes its lane masks by
//! compare and `movemask` (it was 128 single moves and a loop over the lanes). Third, the lane
//! tests of a batch of candidates run before any of its pairs are pushed, so that the blocks'
//! chains of divisions and square roots overlap instead of waiting behind the push loop's
//! mispredicted branches. Callgrind, one thread, `grid_profile pairs 3`: 1.87 G to 1.47 G
//! instructions on `wardlin`'s sections, 2.61 G to 2.42 G on the bench scene. In time, on a shared
//! machine that ran 2 to 2.5 times slower than on the days above (old and new measured
//! alternately): `wardlin`'s sections, one thread, fastest of 15, 66-76 ms before and 56-66 ms
//! after; `bench grid` `pairs_ms` 57-65 ms before and 56-59 ms after.
//!
//! ### With AVX-512
//!
//! On a processor with AVX-512F (detected at run time), four parts run sixteen lanes wide. The
//! AVX2 and baseline kernels remain, and every kernel gives the same cells and the same pairs in
//! the same order. Tests check this kernel against kernel, and the eight-wide covers against the
//! scalar ones.
//!
//! - **Rows of the pair search.** A cell is laid out in blocks of sixteen sections, with one
//!   pointer for every column. With a pointer per column, the row loop spilled its registers.
//!   - A block's boxes are gathered with one 256-bit load per box and a 16 x 8 transpose in
//!     registers.
//!   - Each row tests box overlap, the neighbour rule and the owner rule lane-wise, then keeps
//!     its pairs with one compress. There is no loop over the hits; with AVX2 that loop cost
//!     about as much as the box tests.
//!   - A row with an undecided owner (both covers leave the window, or one is too long to be
//!     described) is redone pair by pair with the key lists.
//! - **The exact test** runs sixteen candidates at once, with the AVX2 operations lane for lane.
//!   A pair in the rounding band is rebuilt from the search-order lines, which keep both ends, so
//!   the scalar test no longer reads the shapes in the caller's order.
//! - **The rebuild's covers.** Eight sections are covered at once in `f64` lanes when their cover
//!   lies within 2 x 2 x 2 cells, which is most hair sections. Every case of the scalar small
//!   mask is computed and then selected: the direction's sign and the one-or-two-cell cases
//!   mispredict in a scalar loop.
//! - **Prefetching.** The rebuild's scattered writes (the entries) and reads (the sections in the
//!   search's order) fetch their lines 16 items ahead.
//!
//! Measured on the 2-core machine, alternating the binaries of the commit before (6012437) and
//! after (`grid_profile both 15`, fastest of 15, with other virtual machines' load coming and
//! going):
//!
//! | threads | phase | before (ms) | after (ms) |
//! |---|---|---|---|
//! | 2 | pair search | 22.2-22.9 | 12.8-13.1 |
//! | 2 | rebuild | 20.8-21.3 | 16.2-17.2 |
//! | 1 | pair search | 39.8-40.9 | 21.6-21.9 |
//! | 1 | rebuild | 31.2-32.3 | 25.0-29.2 |
//!
//! `cargo run --release -- bench grid --json` (medians of seven) gives `total_ms` 26.0-28.0,
//! `build_ms` 14.4-14.8, `pairs_ms` 11.5-11.7 and `ratio` 9.1-10.0 over three runs, with
//! identical pairs; the binary before, run right after, gave 38.1 and 42.3 ms (and 45-53 ms over
//! the previous session). The shared host has slower phases: an hour later the same commands gave
//! 29.5-34.4 ms, and 51.0 ms for the binary before. So the goal of issue 4, under 30 ms on 2
//! cores, is met only while the host runs at its usual speed. Both halves slowed by about a
//! fifth to a quarter (`build_ms` 14.4-14.8 to 18.1-18.3, `pairs_ms` 11.5-11.7 to 13.6-14.5).
//! A processor without AVX-512 runs the AVX2 kernels, at about the figures before.
//!
//! The environment variable `HAIR_GRID_KERNEL` (`avx2` or `baseline`) runs a narrower kernel
//! than the processor has ([`requested_kernel`]), so that one machine measures all of them.
//! `cargo run --release -- bench grid --json` on an AVX-512 machine, two runs each (medians of
//! seven, milliseconds):
//!
//! | kernel | `build_ms` | `pairs_ms` | `total_ms` |
//! |---|---|---|---|
//! | `avx512` | 13.3-14.0 | 10.9-11.2 | 24.6-24.9 |
//! | `avx2` | 13.3-14.3 | 19.6-20.2 | 32.8-34.5 |
//! | `baseline` | 15.9-19.0 | 25.1-28.6 | 41.1-47.0 |
//!
//! Every run found the same 199,478 pairs, identical to parry's and to brute force on the
//! subset. After the AVX2 rows in blocks (below), three runs each on a noisier hour gave
//! `total_ms` 24.9-26.3 (`avx512`), 30.7-38.3 (`avx2`, `pairs_ms` 18.2-21.7) and 37.0-44.4 ms
//! (`baseline`).
//!
//! The rebuild then stopped copying each section twice: once into a 64-byte record (box, ids and
//! core) in the caller's order, once as its shape (19 MB and 16 MB written per rebuild of the
//! bench scene). The pack now reads the caller's sections directly in the search's order, both
//! cache lines a section may straddle fetched ahead, and an LSS reads back from its core in the
//! search's data (`Grid::shape` returns it by value); only the few shapes that are not an LSS
//! are kept. The pack reads two lines per section instead of one, and the covers write far less.
//! `grid_profile build 15`, alternated with the commit before over eight rounds: fastest of 15
//! rebuilds 13.75 ms before and 12.8 ms after (medians of the rounds). Measured the same way and
//! dropped (the code is not kept, so these figures are a record, not something to rerun):
//! writing each section's box and core at its rank from the scatter, which reads the sections
//! in their own order (scattered writes of two lines per section: rebuilds of 15.6-16.2 ms
//! against 13.4-13.7); counting the entries per box cell as each chunk is covered, with the box
//! taken from a pass over the sections' boxes (medians 13.9 against 12.65 ms: the pass cost
//! more than it saved) or from the last rebuild's box (no change: 12.4-12.8 against 12.5-13.3
//! ms).
//!
//! ### Sweeps in crowded cells
//!
//! A simulation's hair is locally parallel and its cells are crowded: `wardlin` at its finest
//! level has 49,344 entries in 138 cells at step 40. A cell of 128 sections or more is now
//! searched as a sweep:
//! - its entries are sorted by box minimum along one axis: the one where the boxes are shortest
//!   against the spread of their minima;
//! - each row stops at the first section whose minimum lies past the row's maximum, since every
//!   later box misses the row's box along that axis.
//!
//! The pairs are the same set; inside a swept cell they come in sweep order, so a simulation's
//! states change with it (the bench scene has no such cell: its three hashes are unchanged).
//! Smaller cells keep their stored order. There the sort costs more than it saves: sweeping
//! every cell of 32 sections or more made the bench scene's search 35% slower, and of 64 or
//! more 8% slower.
//!
//! Measured with `grid_profile pairs 15` on `wardlin`'s sections after 41 steps (1.88 M
//! candidates, 691,521 pairs; written by `cargo run --release -p hair --example grid_sections
//! -- wardlin 41 fine FILE` and read through `HAIR_GRID_SECTIONS=FILE`; the pair hashes
//! `7ce3e7bc15dc211c 1ac77578bd4bbaa` at 6f0dda3), alternated with the commit before over three
//! rounds: the fastest search went from 8.5-9.7 ms to 7.0-8.3 ms. In `hair run wardlin
//! --frames 40 --lod fine`, alternated over four rounds, the fastest `hair_hair` frame went from
//! 17.3-18.3 ms to 16.0-17.7 ms. The bench scene in 3 cm cells (3,730 cells of 127 sections on average;
//! `grid_profile pairs 5 0.03`, a criterion bench too) went from 80 to 43 ms.
//!
//! Measured and dropped: one division instead of two for the exact test's first parameter
//! (operands selected before dividing, the same values). Fastest of 20 single-thread searches
//! on the `wardlin` dump: 14.5-15.5 ms before and after.
//!
//! ### The covers with AVX2
//!
//! A processor with AVX2 but not AVX-512 (as the 2-core machine of these measurements now is)
//! covers eight sections at a time too: the AVX-512 expressions in four `f64` lanes, run on each
//! half of the eight, with compare results and blends in place of mask registers. The ranges and
//! masks are the scalar ones (the same test checks both kernels against `short_line`, and each
//! other), so the cells, candidates and pairs are unchanged: `grid_profile` gives the same three
//! hashes. Callgrind, one thread, half the difference of `build 3` and `build 1`: 271 M to 234 M
//! instructions per rebuild. `grid_profile build 15` alternated with the binary before over
//! eight rounds on a busy host: fastest rebuild 23.9 ms against 25.6 ms on average, faster in 7
//! rounds of 8.
//!
//! Measured on that machine and dropped (the code is not kept):
//! - **AVX2 rows without a hit loop**, after the AVX-512 ones: box, neighbour and owner tests
//!   lane-wise on each group of eight, the kept sections packed to the low lanes through a
//!   256-entry table of lane permutations, and eight pairs stored at once. The same pairs in the
//!   same order, but 452 M instructions per search against 440 M, and slower: fastest search
//!   25.2-27.5 ms against 22.6-25.3 ms over three alternated rounds (31.3-31.7 against
//!   26.6-27.5 ms with a branch that skips the groups keeping nothing). Without mask registers
//!   and a compress, the lane work costs more than the hit loop it removes.
//! - **Sweeping smaller cells.** Every cell of 2, 16, 32 or 64 sections or more as a sweep: the
//!   bench scene's search took 35.8, 32.4-33.0, 29.4 and 24.1-24.3 ms against 22.0-23.6 ms.
//!   Sorting alone, with full rows, took 30.7-31.1 ms: the per-cell sort is the cost.
//! - **A sweep's row ends found eight sections at a time** instead of by binary search (the rows
//!   then test up to seven boxes more, which miss): the same instructions within 0.1% and the
//!   same time on `wardlin`'s sections (13.1-13.3 ms either way).
//! - **The first hits of a row without a loop** (the AVX2 and baseline rows): the first four
//!   hits taken in straight-line code, a slot past the last hit testing the row's own section and
//!   keeping nothing, so that the loop over hits, whose exit depends on how many there are,
//!   runs only for rows with more. Measured on an AVX-512 machine with `HAIR_GRID_KERNEL=avx2`
//!   (`grid_profile pairs 20`, three alternated rounds): fastest search 22.9-23.1 ms against
//!   19.9-20.6 ms; with one slot, 19.9-20.1 ms against 20.1-20.2 ms (no change).
//! - **Smaller cells for `wardlin`'s sections** (the dump of step 41 above, whose default cells
//!   are 137 crowded ones): fastest of 30 searches 7.2 ms by default, 10.6, 8.4, 7.3 and
//!   7.1 ms in cells of 2, 2.5, 3 and 4 cm. Not worth a setting.
//! - **Transparent huge pages** for the large buffers (glibc's `glibc.malloc.hugetlb=1`, which
//!   advises them so): `grid_profile both 10` over eight alternated rounds gave the same
//!   fastest rebuild (23.6 ms on average either way) and a slower search (29.7 against
//!   28.1 ms).
//!
//! ### AVX2 rows in blocks
//!
//! The AVX2 kernel now searches a cell in the AVX-512 kernel's layout: blocks of sixteen
//! sections, every field at a fixed offset from one pointer. It tests eight boxes per compare and
//! drops the hits whose pair an earlier cell surely reports, as before, then takes the neighbour
//! and owner tests hit by hit. With a pointer per column, the row loop had kept about 190
//! instructions of bounds checks, reloaded pointers and spilled registers for every row. A pair
//! the bit sets cannot tell sends the row to the key lists (`Grid::row_blocks`, shared with the
//! AVX-512 kernel). The test of a cover too long to be described is left out of cells that
//! have none.
//!
//! The same cells, candidates and pairs come out in the same order: the three hashes of
//! `grid_profile`, and `hair run wardlin --frames 60 --lod fine` gives `c636109a70c2ead7` with
//! every kernel. Callgrind, one thread, half the difference of `pairs 3` and `pairs 1`: 440 M to
//! 362 M instructions per search. `HAIR_GRID_KERNEL=avx2 grid_profile pairs 20` on an AVX-512
//! machine, alternated with the binary before over three rounds: the fastest search took
//! 18.0-18.3 ms against 20.0-20.2 ms.
//!
//! Measured and dropped:
//! - **The blocks gathered in registers**, eight boxes loaded whole and transposed: 17.9-18.1
//!   ms against 18.1-18.3 ms, no gain for the unsafe code.
//! - **Every box hit sent to the hit loop**, without the lane-wise test of earlier cells: 21.8-22.0
//!   ms.
//! - **Reporting straight away in cells with no cell outside the window**, skipping the owner
//!   test of each hit: 18.0-18.1 against 18.2-18.4 ms, within the noise.
//!
//! ### Where a rebuild's time goes
//!
//! Temporary timers around the rebuild's phases (`grid_profile build 10`, 2 threads, on a day
//! the whole rebuild took 17.8-20 ms): the mean segment length 0.9-1.9 ms (a pass over the 18 MB
//! of sections, which memory bounds), the covers 5.2-6.1, the counts per box cell 1.4-1.8, the
//! prefix over the box cells 0.9-1.5 (one thread), the pair search's order 1.3-2.1, the scatter
//! 3.8-4.9, the copy out of it 0.7-1.0 and the pack into the search's order 2.8-3.6 ms. Only the
//! prefix and the order's inverse run on one thread; splitting the prefix over slabs of the box
//! would save about half a millisecond, and was not done.
//!
//! Output orders are deterministic: the same input gives the same cells, sections and pairs in the
//! same order for any number of rayon threads. No hashing with random state is used: cells are
//! sorted by their keys.
//!
//! ```
//! use hair_grid::{Grid, GridConfig, PairSet, Section};
//! use hair_ssv::{Lss, Point, Ssv};
//!
//! // Two strands of three 1 cm segments, 0.5 mm apart at the tips.
//! let strand = |x: f32, lean: f32| -> Vec<Point> {
//!     (0..4).map(|k| Point::new(x + lean * k as f32, -0.01 * k as f32, 0.0)).collect()
//! };
//! let mut sections = Vec::new();
//! for (s, nodes) in [strand(0.0, 0.0), strand(0.0024, -0.0005)].iter().enumerate() {
//!     for (k, w) in nodes.windows(2).enumerate() {
//!         let shape = Ssv::Line(Lss::new(w[0], w[1], 0.0005));
//!         sections.push(Section { skeleton: s as u32, segment: k as u32, shape });
//!     }
//! }
//! let mut grid = Grid::new(GridConfig::default());
//! grid.rebuild(&sections)?;
//! assert!((grid.cell_size() - 0.01).abs() < 1e-3); // mean segment length
//!
//! let mut pairs = PairSet::new();
//! grid.overlapping_pairs(&mut pairs);
//! // Only the last segments of the two strands overlap; neighbours on a strand are skipped.
//! assert_eq!(pairs.to_vec(), vec![[2, 5]]);
//! # Ok::<(), hair_grid::GridError>(())
//! ```

mod activity;
mod body;
mod cell_key;
mod cover;
mod error;
mod grid;
mod influence;
mod pairs;
pub mod test_scenes;

pub use activity::{Activity, ActivityConfig, ActivityInput, CellActivity, CellState};
pub use body::{BodyCells, BodyGrid};
pub use cell_key::{CellKey, LATTICE_HALF};
pub use error::GridError;
pub use grid::{Grid, GridConfig, Section};
pub use influence::{Cone, InfluenceVolume};
pub use pairs::{PairSet, kernel_name, requested_kernel};

pub use hair_ssv::{Point, Real, Ssv, Vector};
