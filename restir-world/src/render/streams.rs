//! The random streams of the passes, allocated by name in one place, with the build-time check
//! that no two share an id and that every id stays below [`STREAM_COUNT`] (a larger one would
//! alias stream 0 of the next seed).

/// The random streams of the passes, allocated in this one place: each id is mixed into the
/// seed of every invocation of the pass that draws from it (WGSL `render_rng`), so passes draw
/// independent numbers. The WGSL constants `STREAM_*` are generated from [`Stream::ALL`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u32)]
pub enum Stream {
    /// Camera-ray jitter.
    Primary = 0,
    /// GI-ray directions.
    Gi = 1,
    /// NEE at the primary vertex.
    Direct = 2,
    /// NEE at the secondary vertex.
    Indirect = 3,
    WrGenerate = 4,
    WrBuild = 5,
    WrTemporal = 6,
    WrSpatial = 7,
    /// Filling the light tiles.
    LightTiles = 8,
    /// A pixel block's pick of a light tile.
    LightTilePick = 9,
    DiInitial = 10,
    DiTemporal = 11,
    DiSpatial = 12,
    /// The path beyond the secondary vertex (salted by the bounce).
    Path = 13,
    GiTemporal = 14,
    GiSpatial = 15,
}

impl Stream {
    /// Every stream with the suffix of its WGSL constant.
    pub const ALL: [(Stream, &'static str); 16] = [
        (Stream::Primary, "PRIMARY"),
        (Stream::Gi, "GI"),
        (Stream::Direct, "DIRECT"),
        (Stream::Indirect, "INDIRECT"),
        (Stream::WrGenerate, "WR_GENERATE"),
        (Stream::WrBuild, "WR_BUILD"),
        (Stream::WrTemporal, "WR_TEMPORAL"),
        (Stream::WrSpatial, "WR_SPATIAL"),
        (Stream::LightTiles, "LIGHT_TILES"),
        (Stream::LightTilePick, "LIGHT_TILE_PICK"),
        (Stream::DiInitial, "DI_INITIAL"),
        (Stream::DiTemporal, "DI_TEMPORAL"),
        (Stream::DiSpatial, "DI_SPATIAL"),
        (Stream::Path, "PATH"),
        (Stream::GiTemporal, "GI_TEMPORAL"),
        (Stream::GiSpatial, "GI_SPATIAL"),
    ];
}

/// Stream ids per seed: the seed of a render is `seed * STREAM_COUNT + stream`, so changing it
/// changes every image.
pub const STREAM_COUNT: u32 = 16;

/// The build fails when two streams of [`Stream::ALL`] share an id or a WGSL name, or when an
/// id reaches [`STREAM_COUNT`] (raising the count changes every image: say so where it lands).
const _: () = {
    const fn same(a: &str, b: &str) -> bool {
        let (a, b) = (a.as_bytes(), b.as_bytes());
        if a.len() != b.len() {
            return false;
        }
        let mut i = 0;
        while i < a.len() {
            if a[i] != b[i] {
                return false;
            }
            i += 1;
        }
        true
    }
    let all = Stream::ALL;
    let mut i = 0;
    while i < all.len() {
        assert!(
            (all[i].0 as u32) < STREAM_COUNT,
            "a random stream's id reaches STREAM_COUNT (it would alias the next seed's streams)"
        );
        let mut j = i + 1;
        while j < all.len() {
            assert!(
                all[i].0 as u32 != all[j].0 as u32,
                "two random streams share an id"
            );
            assert!(!same(all[i].1, all[j].1), "two random streams share a name");
            j += 1;
        }
        i += 1;
    }
};
