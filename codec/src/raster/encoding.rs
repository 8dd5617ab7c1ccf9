//! How a PNG stores heights: one gray channel, or 24 bits spread over R, G and B by one of the
//! two web-map conventions (DESIGN.md §4).
//!
//! - Mapbox terrain-RGB: h = −10000 + 0.1·(R·65536 + G·256 + B), 0.1 m steps.
//! - Terrarium (Mapzen/AWS): h = R·256 + G + B/256 − 32768, 1/256 m steps.

use std::fmt;
use std::str::FromStr;

use crate::error::ParamError;

/// A height encoding for PNG rasters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Encoding {
    /// Mapbox terrain-RGB.
    TerrainRgb,
    /// Mapzen/AWS Terrarium.
    Terrarium,
    /// The gray value is the height (8- or 16-bit).
    Gray,
}

impl Encoding {
    /// The height quantum of the encoding.
    pub fn step(self) -> f64 {
        match self {
            Self::TerrainRgb => 0.1,
            Self::Terrarium => 1.0 / 256.0,
            Self::Gray => 1.0,
        }
    }

    /// The height an 8-bit RGB pixel encodes; `None` for [`Encoding::Gray`], which has no
    /// colour form.
    pub fn decode_rgb(self, [r, g, b]: [u8; 3]) -> Option<f64> {
        let code = u32::from(r) << 16 | u32::from(g) << 8 | u32::from(b);
        match self {
            // (code − 100000) / 10 is the nearest double to the decimal height; the formula's
            // 0.1·code would add an error in the last bit.
            Self::TerrainRgb => Some((f64::from(code) - 100_000.0) / 10.0),
            // Exact in binary: every term is a multiple of 1/256.
            Self::Terrarium => Some(f64::from(code) / 256.0 - 32_768.0),
            Self::Gray => None,
        }
    }

    /// The other colour encoding, when a PNG's typical code reads as no place on Earth under
    /// `self` and as one under it: the two conventions put ordinary heights in disjoint
    /// ranges of the red channel (terrain-RGB R ≤ 2, Terrarium R = 85…162), so a wrong
    /// `--encoding` gives heights near −32 km or past 800 km rather than an error. `typical`
    /// is the median 24-bit code of the opaque pixels (both decodings rise with the code, so
    /// it decodes to the median height under either).
    ///
    /// Only refused when the other reading is Earth-like: a source outside Earth's range
    /// under both (another planet, a made-up raster) is the caller's to read as they say.
    pub fn misread(self, typical: [u8; 3]) -> Option<Misread> {
        let other = match self {
            Self::TerrainRgb => Self::Terrarium,
            Self::Terrarium => Self::TerrainRgb,
            Self::Gray => return None,
        };
        let asked = self.decode_rgb(typical)?;
        let instead = other.decode_rgb(typical)?;
        // Wider than Earth's −10,935 … 8,849 m for the asked reading (Olympus Mons rises
        // 21.9 km); the other reading must be Earth's, and above −10,000 m, terrain-RGB's
        // zero code, which a blank Terrarium tile of zeros would give.
        let asked_plausible = (-15_000.0..=30_000.0).contains(&asked);
        let instead_earthlike = instead > -10_000.0 && instead <= 9_000.0;
        (!asked_plausible && instead_earthlike).then_some(Misread {
            asked,
            other,
            instead,
        })
    }

    /// The names [`FromStr`] accepts, for messages.
    pub const NAMES: &'static str = "terrain-rgb, terrarium, gray";
}

/// A PNG read under the wrong colour encoding: see [`Encoding::misread`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Misread {
    /// The median height under the encoding asked for, in metres.
    pub asked: f64,
    /// The encoding that reads the PNG as terrain.
    pub other: Encoding,
    /// The median height under `other`.
    pub instead: f64,
}

impl fmt::Display for Encoding {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::TerrainRgb => "terrain-rgb",
            Self::Terrarium => "terrarium",
            Self::Gray => "gray",
        })
    }
}

impl FromStr for Encoding {
    type Err = ParamError;

    /// Accepts `terrain-rgb` (or `terrainrgb`, `mapbox`), `terrarium`, `gray` (or `grey`),
    /// ASCII case-insensitive.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim().to_ascii_lowercase().as_str() {
            "terrain-rgb" | "terrainrgb" | "terrain_rgb" | "mapbox" => Ok(Self::TerrainRgb),
            "terrarium" => Ok(Self::Terrarium),
            "gray" | "grey" => Ok(Self::Gray),
            _ => Err(ParamError::OutOfRange {
                name: "encoding",
                expected: "one of terrain-rgb, terrarium, gray",
                got: s.to_string(),
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_prints_each_name() {
        for e in [Encoding::TerrainRgb, Encoding::Terrarium, Encoding::Gray] {
            assert_eq!(e.to_string().parse::<Encoding>(), Ok(e));
        }
        assert_eq!("Terrain-RGB".parse::<Encoding>(), Ok(Encoding::TerrainRgb));
        assert!("jpeg".parse::<Encoding>().is_err());
    }

    #[test]
    fn decodes_the_published_formulas() {
        // terrain-RGB (1, 134, 160) = −10000 + 0.1·(65536 + 34304 + 160) = 0 m.
        assert_eq!(Encoding::TerrainRgb.decode_rgb([1, 134, 160]), Some(0.0));
        assert_eq!(Encoding::TerrainRgb.decode_rgb([1, 134, 137]), Some(-2.3));
        // Terrarium (128, 0, 0) = 0 m; (128, 1, 128) = 1.5 m.
        assert_eq!(Encoding::Terrarium.decode_rgb([128, 0, 0]), Some(0.0));
        assert_eq!(Encoding::Terrarium.decode_rgb([128, 1, 128]), Some(1.5));
        assert_eq!(Encoding::Gray.decode_rgb([1, 2, 3]), None);
    }

    #[test]
    fn a_wrong_colour_encoding_is_told_by_the_median_code() {
        use Encoding::{Gray, TerrainRgb, Terrarium};
        // 1,000 m in each convention, read under the other: −32,338 m and +854,461 m.
        let terrain_rgb_1000m = [1, 173, 176];
        let terrarium_1000m = [131, 232, 0];
        assert_eq!(TerrainRgb.decode_rgb(terrain_rgb_1000m), Some(1000.0));
        assert_eq!(Terrarium.decode_rgb(terrarium_1000m), Some(1000.0));
        let m = Terrarium.misread(terrain_rgb_1000m).unwrap();
        assert_eq!((m.other, m.instead), (TerrainRgb, 1000.0));
        assert!(m.asked < -32_000.0, "{m:?}");
        let m = TerrainRgb.misread(terrarium_1000m).unwrap();
        assert_eq!((m.other, m.instead), (Terrarium, 1000.0));
        assert!(m.asked > 800_000.0, "{m:?}");
        // Read rightly: nothing to say.
        assert_eq!(TerrainRgb.misread(terrain_rgb_1000m), None);
        assert_eq!(Terrarium.misread(terrarium_1000m), None);
        assert_eq!(Gray.misread(terrarium_1000m), None);
        // The Dead Sea shore and Everest, and near the deepest trench: still right.
        // −411 m and 8849 m in Terrarium, −9923 m in terrain-RGB.
        assert_eq!(Terrarium.misread([126, 101, 0]), None);
        assert_eq!(Terrarium.misread([162, 145, 0]), None);
        assert_eq!(TerrainRgb.misread([0, 3, 2]), None);
        // Olympus Mons (21.9 km) in terrain-RGB: not Earth, but not refused.
        let olympus = [4, 225, 240]; // 319,984 · 0.1 − 10,000 = 21,998.4 m
        assert_eq!(TerrainRgb.decode_rgb(olympus), Some(21_998.4));
        assert_eq!(TerrainRgb.misread(olympus), None);
        // A blank Terrarium tile (all zeros, −32,768 m) reads −10,000 m as terrain-RGB:
        // the floor of its range, not terrain; left to the caller.
        assert_eq!(Terrarium.misread([0, 0, 0]), None);
    }
}
