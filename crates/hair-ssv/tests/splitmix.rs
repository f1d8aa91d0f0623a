//! The fixtures' generator is `rand_xoshiro`'s SplitMix64. It replaced copies of SplitMix64 kept
//! in the workspace's crates, and must give the very streams they gave, or every seeded scene,
//! bench and golden figure would change.

use hair_ssv::test_meshes::SplitMix;

/// For each seed: the first three outputs, the 1,000th, and an FNV-1a fold of the first 1,000,
/// computed with the former copy (state += 0x9E37_79B9_7F4A_7C15, then the two multiply-xorshift
/// rounds and a final xorshift).
const FORMER: [(u64, [u64; 3], u64, u64); 6] = [
    (
        0x0,
        [0xe220a8397b1dcdaf, 0x6e789e6aa1b965f4, 0x06c45d188009454f],
        0x14e0abb2bfcf7c3e,
        0xc582f1700cffef42,
    ),
    (
        0x1,
        [0x910a2dec89025cc1, 0xbeeb8da1658eec67, 0xf893a2eefb32555e],
        0xe71894b1b5034fb7,
        0x7948dbdd64c7994f,
    ),
    (
        0x7,
        [0x63cbe1e459320dd7, 0x044c3cd7f43c661c, 0xe6984080bab12a02],
        0x9793fb91046fffee,
        0x9631bb8780f10615,
    ),
    (
        0x2a,
        [0xbdd732262feb6e95, 0x28efe333b266f103, 0x47526757130f9f52],
        0x66091ca85313fa68,
        0x536cee532ddb4678,
    ),
    (
        0x5eed55f,
        [0x6e0ea9f1a32ccfb3, 0x70c9c472ad81cf51, 0x8d16a7cfde512db5],
        0xfbe91d5f25b6f179,
        0xd3da97c1b755aeb6,
    ),
    (
        0xffffffffffffffff,
        [0xe4d971771b652c20, 0xe99ff867dbf682c9, 0x382ff84cb27281e9],
        0x82bd385046d33fbf,
        0x25f69eac271beb89,
    ),
];

#[test]
fn the_generator_gives_the_streams_of_the_former_splitmix_copies() {
    for (seed, first, thousandth, fold) in FORMER {
        let mut rng = SplitMix::new(seed);
        let v: Vec<u64> = (0..1000).map(|_| rng.next_u64()).collect();
        assert_eq!(v[..3], first, "seed {seed:#x}");
        assert_eq!(v[999], thousandth, "seed {seed:#x}");
        let h = v.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &x| {
            (h ^ x).wrapping_mul(0x0100_0000_01b3)
        });
        assert_eq!(h, fold, "seed {seed:#x}");
    }
}

#[test]
fn unit_and_range_take_the_top_24_bits() {
    let (mut a, mut b) = (SplitMix::new(3), SplitMix::new(3));
    for _ in 0..100 {
        let bits = b.next_u64();
        let u = (bits >> 40) as f32 / (1u64 << 24) as f32;
        assert_eq!(a.unit().to_bits(), u.to_bits());
        let bits = b.next_u64();
        let u = (bits >> 40) as f32 / (1u64 << 24) as f32;
        assert_eq!(a.range(-2.0, 3.0).to_bits(), (-2.0 + 5.0 * u).to_bits());
    }
}
