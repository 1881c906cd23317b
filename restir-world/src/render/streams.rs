//! The random streams of the passes and their sub-streams, allocated by name in one place, with
//! the build-time checks that no two streams share an id, that every id stays below
//! [`STREAM_COUNT`] (a larger one would alias stream 0 of the next seed), and that no two
//! sub-streams of one stream share a salt.

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

/// Whether two names are equal (in a const context).
const fn same_name(a: &str, b: &str) -> bool {
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

/// The build fails when two streams of [`Stream::ALL`] share an id or a WGSL name, or when an
/// id reaches [`STREAM_COUNT`] (raising the count changes every image: say so where it lands).
const _: () = {
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
            assert!(
                !same_name(all[i].1, all[j].1),
                "two random streams share a name"
            );
            j += 1;
        }
        i += 1;
    }
};

/// A sub-stream: salts `first .. first + count` of each of `streams` (WGSL
/// `render_rng_salted(i, stream, salt)`: the salt is mixed into the seed's top 12 bits, so
/// that with seeds below 2^16 no two (stream, salt) pairs of a render share a seed), allocated
/// here by name like the streams, so that no two uses of one stream draw the same numbers. The
/// WGSL constant `SALT_{name}` is `first`; a use with `count` > 1 adds its index (a bounce, a
/// pass) below `count`.
#[derive(Debug, Clone, Copy)]
pub struct SubStream {
    pub name: &'static str,
    pub streams: &'static [Stream],
    pub first: u32,
    pub count: u32,
}

/// Salts are below this (12 bits above the seed's 20).
pub const SALT_LIMIT: u32 = 1 << 12;

/// Per-bounce sub-streams cover the bounces of a path and its MIS ray.
const BOUNCE_SALTS: u32 = crate::sampling::MAX_BOUNCES + 2;

/// Every sub-stream a pass draws from beyond its stream's salt 0 (a pass that draws from salt 0
/// of a stream no other pass salts is not listed).
pub const SUB_STREAMS: [SubStream; 14] = [
    SubStream {
        name: "PATH_BOUNCE",
        streams: &[Stream::Path],
        first: 0,
        count: BOUNCE_SALTS,
    },
    SubStream {
        name: "WR_PATH_ESTIMATE",
        streams: &[Stream::Path],
        first: 0x800,
        count: BOUNCE_SALTS,
    },
    SubStream {
        name: "WR_PATH_RESERVOIR",
        streams: &[Stream::Path],
        first: 0x900,
        count: BOUNCE_SALTS,
    },
    SubStream {
        name: "CACHE_UPDATE",
        streams: &[Stream::Path],
        first: 0xa00,
        count: 1,
    },
    SubStream {
        name: "CACHE_RESOLVE",
        streams: &[Stream::Path],
        first: 0xa01,
        count: 1,
    },
    SubStream {
        name: "CACHE_ACCUMULATE",
        streams: &[Stream::Path],
        first: 0xa02,
        count: 1,
    },
    SubStream {
        name: "CANDIDATES",
        streams: &[Stream::DiInitial, Stream::WrGenerate],
        first: 0,
        count: 1,
    },
    SubStream {
        name: "ESTIMATE",
        streams: &[Stream::DiInitial, Stream::WrGenerate],
        first: 0xffe,
        count: 1,
    },
    SubStream {
        name: "WR_REUSE_PASS",
        streams: &[Stream::WrTemporal, Stream::WrSpatial],
        first: 0,
        count: 64,
    },
    SubStream {
        name: "WR_SPATIAL_ESTIMATE",
        streams: &[Stream::WrSpatial],
        first: 0xfff,
        count: 1,
    },
    SubStream {
        name: "GI_TEMPORAL_PASS",
        streams: &[Stream::GiTemporal],
        first: 0,
        count: 1,
    },
    SubStream {
        name: "GI_SUBPATH",
        streams: &[Stream::GiTemporal],
        first: 1,
        count: 1,
    },
    GRID_WORLD_RESTIR,
    GRID_WORLD_RESTIR_GI,
];

/// The jitter of world-restir's grid build.
pub const GRID_WORLD_RESTIR: SubStream = SubStream {
    name: "GRID_WORLD_RESTIR",
    streams: &[Stream::WrBuild],
    first: 0,
    count: 1,
};

/// The jitter of world-restir-gi's grid build: apart from world-restir's, which a method may
/// build in the same frame.
pub const GRID_WORLD_RESTIR_GI: SubStream = SubStream {
    name: "GRID_WORLD_RESTIR_GI",
    streams: &[Stream::WrBuild],
    first: 1,
    count: 1,
};

/// The WGSL constants `SALT_*` of [`SUB_STREAMS`].
pub fn sub_streams_wgsl() -> String {
    SUB_STREAMS
        .iter()
        .map(|s| format!("const SALT_{}: u32 = {:#x}u;\n", s.name, s.first))
        .collect()
}

/// The first pair of `list` that clash: two sub-streams of one stream whose salts overlap, or
/// two of one name; a sub-stream whose salts reach [`SALT_LIMIT`] clashes with itself.
pub const fn first_clash(list: &[SubStream]) -> Option<(usize, usize)> {
    const fn shares_stream(a: &SubStream, b: &SubStream) -> bool {
        let mut i = 0;
        while i < a.streams.len() {
            let mut j = 0;
            while j < b.streams.len() {
                if a.streams[i] as u32 == b.streams[j] as u32 {
                    return true;
                }
                j += 1;
            }
            i += 1;
        }
        false
    }
    let mut i = 0;
    while i < list.len() {
        if list[i].count == 0 || list[i].first + list[i].count > SALT_LIMIT {
            return Some((i, i));
        }
        let mut j = i + 1;
        while j < list.len() {
            let apart = list[i].first + list[i].count <= list[j].first
                || list[j].first + list[j].count <= list[i].first;
            if same_name(list[i].name, list[j].name)
                || (!apart && shares_stream(&list[i], &list[j]))
            {
                return Some((i, j));
            }
            j += 1;
        }
        i += 1;
    }
    None
}

/// The build fails when two sub-streams of one stream share a salt or a name, or a salt
/// reaches [`SALT_LIMIT`].
const _: () = assert!(
    first_clash(&SUB_STREAMS).is_none(),
    "two sub-streams of one random stream share salts (or a name)"
);

#[cfg(test)]
mod tests {
    use super::*;

    /// The check the build makes sees a clash: the radiance cache's salts as they were
    /// (0x800..0x802 of the path's stream) against world-restir's per-bounce estimates (0x800 +
    /// bounce), and one name twice; and passes the shipped table.
    #[test]
    fn clashing_sub_streams_are_found() {
        let old_cache = SubStream {
            name: "CACHE_ACCUMULATE",
            streams: &[Stream::Path],
            first: 0x802,
            count: 1,
        };
        let list = [SUB_STREAMS[1], old_cache];
        assert_eq!(first_clash(&list), Some((0, 1)));
        let other_stream = SubStream {
            streams: &[Stream::Gi],
            ..old_cache
        };
        assert_eq!(first_clash(&[SUB_STREAMS[1], other_stream]), None);
        assert_eq!(first_clash(&[old_cache, other_stream]), Some((0, 1)));
        assert_eq!(first_clash(&SUB_STREAMS), None);
        let wgsl = sub_streams_wgsl();
        assert!(wgsl.contains("const SALT_WR_PATH_ESTIMATE: u32 = 0x800u;"));
        assert_eq!(wgsl.lines().count(), SUB_STREAMS.len());
    }
}
