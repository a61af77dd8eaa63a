//! The command line's whole-number flags, each parsed against the range the scene file's key
//! takes, in the same words ([`renderer::load::scene_file::range_message`]): `--width -5`,
//! `--width=-5` and `--width abc` all say "must be in 1..=16384", as `image.width = 0` does.
//! Negative numbers are taken as values (not as flags), so no error suggests `-- -5`.

use renderer::load::scene_file::range_message;
use std::ops::RangeInclusive;

/// A parser for a flag taking a whole number in `range`.
pub fn whole(
    range: RangeInclusive<u32>,
) -> impl Fn(&str) -> Result<u32, String> + Clone + Send + Sync + 'static {
    move |text| parse(text, &range).ok_or_else(|| range_message(&range, &text))
}

/// `--max-depth`'s parser: its range, explained as the scene file's key explains it.
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
        assert_eq!(depth("5"), Ok(5));
        assert!(depth("1").unwrap_err().starts_with("must be in 2..=64"));
        assert_eq!(seed("7"), Ok(7));
        assert!(seed("-1").is_err());
    }
}
