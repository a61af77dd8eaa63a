//! The command line's whole-number flags, in the words of the scene file's keys
//! ([`renderer::load::scene_file::range_message`]): `--width -5`, `--width=-5` and
//! `--width abc` all say "must be in 1..=16384", as `image.width = 0` does. A flag that gives
//! a scene-file key ([`key_value`]) is range-checked once, with the file it is merged into;
//! the others ([`whole`]) here. Negative numbers are taken as values (not as flags), so no
//! error suggests `-- -5`.

use renderer::load::scene_file::range_message;
use std::ops::RangeInclusive;

/// A parser for a flag taking a whole number in `range`.
pub fn whole(
    range: RangeInclusive<u32>,
) -> impl Fn(&str) -> Result<u32, String> + Clone + Send + Sync + 'static {
    move |text| parse(text, &range).ok_or_else(|| range_message(&range, &text))
}

/// A parser for a flag that gives a scene-file key's value (`--width` is `image.width`): any
/// whole number a u32 holds, in the key's words otherwise. Its range is the key's, checked
/// once with the scene file it is merged into (`crate::request`).
pub fn key_value(
    range: RangeInclusive<u32>,
) -> impl Fn(&str) -> Result<u32, String> + Clone + Send + Sync + 'static {
    move |text| parse(text, &(0..=u32::MAX)).ok_or_else(|| range_message(&range, &text))
}

/// `render --max-depth`'s parser ([`key_value`]), in the words the scene file's key uses.
pub fn depth_value(text: &str) -> Result<u32, String> {
    parse(text, &(0..=u32::MAX)).ok_or_else(|| renderer::integrator::path::depth_message(&text))
}

/// `bench --max-depth`'s parser (no scene-file key: checked here), in the key's words.
pub fn depth(text: &str) -> Result<u32, String> {
    parse(text, &renderer::integrator::path::DEPTH_RANGE)
        .ok_or_else(|| renderer::integrator::path::depth_message(&text))
}

/// `--seed`'s parser: any u64.
pub fn seed(text: &str) -> Result<u64, String> {
    text.trim().parse::<u64>().map_err(|_| format!("must be in 0..={}, got {text}", u64::MAX))
}

fn parse(text: &str, range: &RangeInclusive<u32>) -> Option<u32> {
    let v = text.trim().parse::<i128>().ok()?;
    u32::try_from(v).ok().filter(|v| range.contains(v))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bad_value_names_the_range_the_scene_file_names() {
        let side = whole(renderer::load::scene_file::IMAGE_SIDE);
        assert_eq!(side("640"), Ok(640));
        assert_eq!(side(" 16384"), Ok(16384));
        for bad in ["-5", "0", "16385", "abc", "1e3", "99999999999999999999999", ""] {
            assert_eq!(side(bad), Err(format!("must be in 1..=16384, got {bad}")), "{bad:?}");
        }
        // A key's value parses whatever its range; the range is the key's check.
        let width = key_value(renderer::load::scene_file::IMAGE_SIDE);
        assert_eq!((width("0"), width("99999")), (Ok(0), Ok(99999)));
        for bad in ["-5", "abc", "1e3", "99999999999999999999999", ""] {
            assert_eq!(width(bad), Err(format!("must be in 1..=16384, got {bad}")), "{bad:?}");
        }
        assert_eq!((depth_value("5"), depth_value("1")), (Ok(5), Ok(1)));
        assert!(depth_value("-1").unwrap_err().starts_with("must be in 2..=64"));
        assert_eq!(depth("5"), Ok(5));
        assert!(depth("1").unwrap_err().starts_with("must be in 2..=64"));
        assert_eq!(seed("7"), Ok(7));
        assert!(seed("-1").is_err());
    }
}
