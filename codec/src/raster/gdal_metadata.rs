//! GDAL's band scale and offset, from the GDAL_METADATA TIFF tag (42112): the stored samples
//! are codes, and a height is `code · scale + offset` (GDAL's "unscaled" value), as a DEM
//! packed into int16 at half-metre steps, or with a datum moved, is written.
//!
//! The tag is a small XML document of `<Item name=… sample=… role=…>value</Item>` elements;
//! GDAL writes a band's scale and offset as items with `role="scale"` and `role="offset"` and
//! the band's 0-based `sample`. Only those two are read, for band 1 (sample 0), by a scan for
//! the elements rather than an XML parser: nothing else in the document is interpreted.

/// A band's scale and offset: `height = code · scale + offset`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Scaling {
    pub scale: f64,
    pub offset: f64,
}

impl Scaling {
    /// The height of stored code `code`.
    pub fn apply(self, code: f64) -> f64 {
        code * self.scale + self.offset
    }

    /// The height step of integer codes: every height is a whole multiple of |scale| when the
    /// offset is one too, as the reader's contract for [`Heightmap::step`] asks; `None`
    /// otherwise, so the caller picks a step as it does for float rasters.
    ///
    /// [`Heightmap::step`]: super::Heightmap::step
    pub fn int_step(self) -> Option<f64> {
        let k = self.offset / self.scale;
        ((k - k.round()).abs() <= 1e-9 * k.abs().max(1.0)).then_some(self.scale.abs())
    }
}

/// Band 1's scaling from the GDAL_METADATA text: `None` when it declares neither a scale nor
/// an offset (GDAL's defaults, 1 and 0, then stand for the one it leaves out).
///
/// # Errors
/// The offending item, when a scale or offset is not a finite number or the scale is 0
/// (every height would be the offset).
pub(super) fn band1_scaling(xml: &str) -> Result<Option<Scaling>, String> {
    let mut scale = None;
    let mut offset = None;
    for (attributes, value) in items(xml) {
        if attribute(attributes, "sample") != Some("0") {
            continue;
        }
        let slot = match attribute(attributes, "role") {
            Some("scale") => &mut scale,
            Some("offset") => &mut offset,
            _ => continue,
        };
        let text = value.trim();
        match text.parse::<f64>() {
            Ok(v) if v.is_finite() => *slot = Some(v),
            _ => {
                return Err(format!(
                    "GDAL_METADATA item <Item {attributes}>{text}</Item> is not a finite number"
                ))
            }
        }
    }
    if scale == Some(0.0) {
        return Err("GDAL_METADATA scale 0 would make every height the offset".to_string());
    }
    Ok((scale.is_some() || offset.is_some()).then(|| Scaling {
        scale: scale.unwrap_or(1.0),
        offset: offset.unwrap_or(0.0),
    }))
}

/// The `<Item …>value</Item>` elements of `xml`, as (attribute text, value).
fn items(xml: &str) -> impl Iterator<Item = (&str, &str)> {
    xml.split("<Item").skip(1).filter_map(|rest| {
        // `<Items>` or another element named alike is not an item.
        let rest = rest.strip_prefix(|c: char| c.is_ascii_whitespace())?;
        let (attributes, rest) = rest.split_once('>')?;
        let (value, _) = rest.split_once("</Item>")?;
        Some((attributes, value))
    })
}

/// The value of attribute `name` in an element's attribute text (quoted with " or ').
fn attribute<'a>(attributes: &'a str, name: &str) -> Option<&'a str> {
    let mut rest = attributes;
    while let Some(at) = rest.find(name) {
        let before = rest[..at].chars().next_back();
        let after = rest[at + name.len()..].trim_start();
        rest = &rest[at + name.len()..];
        // A whole attribute name (`sample`, not `subsample`), then `=` and a quoted value.
        if before.is_some_and(|c| !c.is_ascii_whitespace()) {
            continue;
        }
        let Some(after) = after.strip_prefix('=') else {
            continue;
        };
        let after = after.trim_start();
        let quote = after.chars().next().filter(|&q| q == '"' || q == '\'')?;
        return after[1..].split_once(quote).map(|(value, _)| value);
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_band_1s_scale_and_offset_as_gdal_writes_them() {
        let xml =
            "<GDALMetadata>\n  <Item name=\"OFFSET\" sample=\"0\" role=\"offset\">200</Item>\n  \
                   <Item name=\"SCALE\" sample=\"0\" role=\"scale\">0.5</Item>\n</GDALMetadata>";
        let s = band1_scaling(xml).unwrap().unwrap();
        assert_eq!(
            s,
            Scaling {
                scale: 0.5,
                offset: 200.0
            }
        );
        assert_eq!((s.apply(100.0), s.apply(2128.0)), (250.0, 1264.0));
        assert_eq!(s.int_step(), Some(0.5));
    }

    #[test]
    fn other_bands_dataset_items_and_other_roles_are_not_band_1s() {
        let xml = "<GDALMetadata><Item name=\"SCALE\" sample=\"1\" role=\"scale\">3</Item>\
                   <Item name=\"AREA_OR_POINT\">Area</Item>\
                   <Item name=\"UNITTYPE\" sample=\"0\" role=\"unittype\">m</Item>\
                   <Item name=\"STATS\" subsample=\"0\" role='scale'>9</Item></GDALMetadata>";
        assert_eq!(band1_scaling(xml), Ok(None));
        assert_eq!(band1_scaling(""), Ok(None));
    }

    #[test]
    fn an_offset_alone_keeps_a_scale_of_1_and_single_quotes_read() {
        let xml = "<GDALMetadata><Item name='OFFSET' sample='0' role='offset'> -10.5 </Item></GDALMetadata>";
        let s = band1_scaling(xml).unwrap().unwrap();
        assert_eq!(
            s,
            Scaling {
                scale: 1.0,
                offset: -10.5
            }
        );
        // -10.5 is no whole number of metres: integer codes then have no step of their own.
        assert_eq!(s.int_step(), None);
        // 0.1 m codes from -10000 m (terrain-RGB's): a whole number of steps, to rounding.
        let s = Scaling {
            scale: 0.1,
            offset: -10_000.0,
        };
        assert_eq!(s.int_step(), Some(0.1));
    }

    #[test]
    fn a_scale_that_is_not_a_number_or_is_0_is_refused_naming_it() {
        let bad = "<Item name=\"SCALE\" sample=\"0\" role=\"scale\">half</Item>";
        let e = band1_scaling(bad).unwrap_err();
        assert!(e.contains(">half</Item> is not a finite number"), "{e}");
        let zero = "<Item name=\"SCALE\" sample=\"0\" role=\"scale\">0</Item>";
        assert!(band1_scaling(zero).unwrap_err().contains("scale 0"));
        let inf = "<Item name=\"OFFSET\" sample=\"0\" role=\"offset\">inf</Item>";
        assert!(band1_scaling(inf).is_err());
    }
}
