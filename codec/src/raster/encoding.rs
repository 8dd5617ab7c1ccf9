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

    /// The names [`FromStr`] accepts, for messages.
    pub const NAMES: &'static str = "terrain-rgb, terrarium, gray";
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
}
