//! Fast path for the JSON the contract's writers produce: one flat object whose keys are the
//! message's fields, without escapes or extra keys.
//!
//! It accepts only what serde_json would accept for the same type, and gives up (`None`) on
//! anything else, extra keys and escaped strings included; the caller then decodes with
//! serde, which handles the general case and names what is wrong. Numbers are parsed with
//! the standard library's correctly rounded `f64` parser.

use crate::contract::{Message, PropKind, PropValue};

/// Decodes `data` as `T` if it has the plain shape; `None` means "ask serde".
pub fn parse<T: Message>(data: &[u8]) -> Option<T> {
    let mut c = Cursor { data, pos: 0 };
    let mut msg = T::default();
    let mut seen: u64 = 0; // bit 0: stamp_ns, bit i+1: property i
    c.skip_ws();
    c.expect(b'{')?;
    c.skip_ws();
    if c.peek()? != b'}' {
        loop {
            c.skip_ws();
            let key = c.string()?;
            c.skip_ws();
            c.expect(b':')?;
            c.skip_ws();
            let bit = if key == b"stamp_ns" {
                msg.set_stamp_ns(c.integer()?);
                0
            } else {
                let index = T::PROPERTIES
                    .iter()
                    .position(|p| p.name.as_bytes() == key)?;
                let value = match T::PROPERTIES[index].kind {
                    PropKind::F64 => PropValue::F64(c.number()?),
                    PropKind::Vec3 => PropValue::Vec3(c.vector3()?),
                    PropKind::OptF64 => PropValue::OptF64(if c.literal(b"null") {
                        None
                    } else {
                        Some(c.number()?)
                    }),
                    PropKind::Bool => PropValue::Bool(if c.literal(b"true") {
                        true
                    } else if c.literal(b"false") {
                        false
                    } else {
                        return None;
                    }),
                    PropKind::Str => PropValue::Str(std::str::from_utf8(c.string()?).ok()?),
                };
                if !msg.set(index, value) {
                    return None;
                }
                index + 1
            };
            if seen & (1 << bit) != 0 {
                return None; // duplicate key: serde reports it
            }
            seen |= 1 << bit;
            c.skip_ws();
            match c.next()? {
                b',' => continue,
                b'}' => break,
                _ => return None,
            }
        }
    } else {
        c.pos += 1;
    }
    c.skip_ws();
    if c.pos != data.len() {
        return None;
    }
    let required = T::PROPERTIES
        .iter()
        .enumerate()
        .filter(|(_, p)| p.required())
        .fold(1u64, |acc, (i, _)| acc | 1 << (i + 1));
    (seen & required == required).then_some(msg)
}

struct Cursor<'a> {
    data: &'a [u8],
    pos: usize,
}

impl<'a> Cursor<'a> {
    fn peek(&self) -> Option<u8> {
        self.data.get(self.pos).copied()
    }

    fn next(&mut self) -> Option<u8> {
        let b = self.peek()?;
        self.pos += 1;
        Some(b)
    }

    fn expect(&mut self, byte: u8) -> Option<()> {
        (self.next()? == byte).then_some(())
    }

    fn skip_ws(&mut self) {
        while matches!(self.peek(), Some(b' ' | b'\t' | b'\n' | b'\r')) {
            self.pos += 1;
        }
    }

    fn literal(&mut self, word: &[u8]) -> bool {
        let hit = self.data[self.pos..].starts_with(word);
        if hit {
            self.pos += word.len();
        }
        hit
    }

    /// A string without escapes or control characters; the bytes between the quotes.
    fn string(&mut self) -> Option<&'a [u8]> {
        self.expect(b'"')?;
        let start = self.pos;
        loop {
            match self.next()? {
                b'"' => return Some(&self.data[start..self.pos - 1]),
                b'\\' => return None,
                b if b < 0x20 => return None,
                _ => {}
            }
        }
    }

    /// The text of a JSON number (strict grammar), and whether it is an integer.
    fn number_text(&mut self) -> Option<(&'a [u8], bool)> {
        let start = self.pos;
        let digits = |c: &mut Self| {
            let s = c.pos;
            while matches!(c.peek(), Some(b'0'..=b'9')) {
                c.pos += 1;
            }
            c.pos - s
        };
        if self.peek() == Some(b'-') {
            self.pos += 1;
        }
        let lead = self.peek()?;
        let n = digits(self);
        if n == 0 || (lead == b'0' && n > 1) {
            return None;
        }
        let mut integer = true;
        if self.peek() == Some(b'.') {
            self.pos += 1;
            integer = false;
            if digits(self) == 0 {
                return None;
            }
        }
        if matches!(self.peek(), Some(b'e' | b'E')) {
            self.pos += 1;
            integer = false;
            if matches!(self.peek(), Some(b'+' | b'-')) {
                self.pos += 1;
            }
            if digits(self) == 0 {
                return None;
            }
        }
        Some((&self.data[start..self.pos], integer))
    }

    /// A finite number (an out-of-range one is left to serde to report).
    fn number(&mut self) -> Option<f64> {
        let (text, _) = self.number_text()?;
        // SAFETY: `number_text` admits only the ASCII bytes `-+.eE0-9`, so `text` is UTF-8.
        // (Checking again costs about a tenth of the whole ingest.) The test
        // `number_text_holds_only_ascii_number_bytes` backs it on a million random inputs.
        let text = unsafe { std::str::from_utf8_unchecked(text) };
        let v: f64 = text.parse().ok()?;
        v.is_finite().then_some(v)
    }

    /// An integer that fits an i64.
    fn integer(&mut self) -> Option<i64> {
        let (text, integer) = self.number_text()?;
        if !integer {
            return None;
        }
        let (negative, digits) = match text.split_first()? {
            (b'-', rest) => (true, rest),
            _ => (false, text),
        };
        let mut v: i64 = 0;
        for &d in digits {
            let d = i64::from(d - b'0');
            v = v.checked_mul(10)?;
            v = if negative {
                v.checked_sub(d)?
            } else {
                v.checked_add(d)?
            };
        }
        Some(v)
    }

    fn vector3(&mut self) -> Option<[f64; 3]> {
        self.expect(b'[')?;
        let mut v = [0.0; 3];
        for (i, slot) in v.iter_mut().enumerate() {
            self.skip_ws();
            *slot = self.number()?;
            self.skip_ws();
            self.expect(if i < 2 { b',' } else { b']' })?;
        }
        Some(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contract::{Dvl, Imu, PositionFix};

    /// Every input: the fast path either agrees with serde exactly or declines.
    fn agrees<T: Message>(text: &str) -> Option<T> {
        let fast = parse::<T>(text.as_bytes());
        let slow = serde_json::from_str::<T>(text).ok();
        if let Some(f) = &fast {
            assert_eq!(
                Some(f),
                slow.as_ref(),
                "fast path accepted what serde decodes differently: {text}"
            );
        }
        fast
    }

    #[test]
    fn decodes_the_plain_shape() {
        let m: Imu = agrees(r#"{"stamp_ns":1700000000000000000,"angular_velocity":[0.001,-2e-3,0],"specific_force":[0.1, -0.2 ,-9.81]}"#).unwrap();
        assert_eq!(m.angular_velocity, [0.001, -0.002, 0.0]);
        let d: Dvl =
            agrees(r#" { "stamp_ns" : 5 , "velocity":[1,2,3], "valid":false, "altitude":null } "#)
                .unwrap();
        assert_eq!(d.altitude, None);
        let d: Dvl = agrees(r#"{"stamp_ns":5,"velocity":[1,2,3],"valid":true}"#).unwrap();
        assert!(d.valid);
        let p: PositionFix = agrees(
            r#"{"stamp_ns":5,"north_m":1,"east_m":2,"down_m":3.5,"sigma_m":0.1,"label":"mark é"}"#,
        )
        .unwrap();
        assert_eq!(p.label, "mark é");
    }

    #[test]
    fn declines_what_it_does_not_handle_or_serde_rejects() {
        let cases = [
            r#"{"stamp_ns":5,"angular_velocity":[0,0,0],"specific_force":[0,0,0],"x":1}"#,
            r#"{"stamp_ns":5,"angular_velocity":[0,0,0]}"#,
            r#"{"stamp_ns":5.0,"angular_velocity":[0,0,0],"specific_force":[0,0,0]}"#,
            r#"{"stamp_ns":05,"angular_velocity":[0,0,0],"specific_force":[0,0,0]}"#,
            r#"{"stamp_ns":5,"angular_velocity":[0,0,0],"specific_force":[0,0,1e400]}"#,
            r#"{"stamp_ns":5,"angular_velocity":[NaN,0,0],"specific_force":[0,0,0]}"#,
            r#"{"stamp_ns":5,"angular_velocity":[0,0],"specific_force":[0,0,0]}"#,
            r#"{"stamp_ns":5,"angular_velocity":[0,0,0,0],"specific_force":[0,0,0]}"#,
            r#"{"stamp_ns":5,"stamp_ns":6,"angular_velocity":[0,0,0],"specific_force":[0,0,0]}"#,
            r#"{"stamp_ns":5,"angular_velocity":[0,0,0],"specific_force":[0,0,0]} x"#,
            r#"{"stamp_ns":5,"angular_velocity":[1.,0,0],"specific_force":[0,0,0]}"#,
            r#"{"stamp_ns":5,"angular_velocity":[-,0,0],"specific_force":[0,0,0]}"#,
            r#"{"stamp\u005fns":5,"angular_velocity":[0,0,0],"specific_force":[0,0,0]}"#,
            r#"{"stamp_ns":99999999999999999999,"angular_velocity":[0,0,0],"specific_force":[0,0,0]}"#,
            r#"{"stamp_ns":5,"angular_velocity":[0,0,0],"specific_force":[0,0,0],}"#,
            "",
            "{",
            "[]",
        ];
        for text in cases {
            assert!(agrees::<Imu>(text).is_none(), "{text}");
        }
        assert!(agrees::<PositionFix>(
            "{\"stamp_ns\":5,\"north_m\":1,\"east_m\":2,\"sigma_m\":0.1,\"label\":\"a\tb\"}"
        )
        .is_none());
        assert!(agrees::<Dvl>(r#"{"stamp_ns":5,"velocity":[1,2,3],"valid":1}"#).is_none());
    }

    #[test]
    fn agrees_with_serde_on_mutated_messages() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let seeds = [
            r#"{"stamp_ns":1700000000000000000,"angular_velocity":[0.001,-2e-3,0],"specific_force":[0.1,-0.2,-9.81]}"#,
            r#"{"stamp_ns":5,"velocity":[1.5,0,-0.01],"valid":true,"altitude":12.5}"#,
            r#"{"stamp_ns":5,"north_m":1,"east_m":-2.5,"down_m":null,"sigma_m":0.05,"label":"start"}"#,
        ];
        let alphabet = b"0123456789.eE-+,:[]{}\" nultrfas\\x";
        let mut accepted = 0;
        for _ in 0..30_000 {
            let mut text = seeds[rng.random_range(0..seeds.len())].as_bytes().to_vec();
            for _ in 0..rng.random_range(1..3) {
                let i = rng.random_range(0..text.len());
                let c = alphabet[rng.random_range(0..alphabet.len())];
                match rng.random_range(0..3) {
                    0 => text[i] = c,
                    1 => text.insert(i, c),
                    _ => {
                        text.remove(i);
                    }
                }
            }
            let Ok(text) = String::from_utf8(text) else {
                continue;
            };
            let hits = [
                agrees::<Imu>(&text).is_some(),
                agrees::<Dvl>(&text).is_some(),
                agrees::<PositionFix>(&text).is_some(),
            ];
            accepted += hits.iter().filter(|h| **h).count();
        }
        // Some mutations stay valid (a digit changed): those exercise agreement on values.
        assert!(accepted > 1000, "{accepted}");
    }

    #[test]
    fn agrees_with_serde_on_many_generated_numbers() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        for _ in 0..20_000 {
            let x: f64 = rng.random_range(-1e3..1e3) * 10f64.powi(rng.random_range(-12..6));
            let text = format!(
                r#"{{"stamp_ns":{},"angular_velocity":[{x},{:e},{}],"specific_force":[{:.6},0,{}]}}"#,
                rng.random_range(0..i64::MAX),
                x * 3.0,
                -x,
                x / 7.0,
                serde_json::to_string(&(x * 1e-5)).unwrap()
            );
            assert!(agrees::<Imu>(&text).is_some(), "{text}");
        }
    }
}

#[cfg(test)]
mod number_bytes {
    use super::Cursor;
    use rand::{Rng, SeedableRng};

    /// What makes the `from_utf8_unchecked` in `number` sound: whatever the input (number
    /// characters mixed with any byte, multi-byte UTF-8 and invalid UTF-8 among them), the
    /// text `number_text` returns holds only the bytes `-+.eE0-9`, and it is where the
    /// cursor stood.
    #[test]
    fn number_text_holds_only_ascii_number_bytes() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let alphabet = b"-+.eE0123456789";
        let mut returned = 0;
        for _ in 0..1_000_000 {
            let len = rng.random_range(0..12);
            let data: Vec<u8> = (0..len)
                .map(|_| {
                    if rng.random_bool(0.8) {
                        alphabet[rng.random_range(0..alphabet.len())]
                    } else {
                        rng.random()
                    }
                })
                .collect();
            let start = rng.random_range(0..=data.len());
            let mut c = Cursor {
                data: &data,
                pos: start,
            };
            if let Some((text, _)) = c.number_text() {
                returned += 1;
                assert!(
                    text.iter().all(|b| alphabet.contains(b)),
                    "{data:?} from {start}: {text:?}"
                );
                assert_eq!(text, &data[start..c.pos]);
            }
        }
        assert!(returned > 100_000, "{returned}");
    }
}

#[cfg(test)]
mod coverage {
    //! The fast path must actually serve the logs the project writes.
    use super::parse;
    use crate::contract::*;
    use crate::sim::synthetic::{write_survey, SurveySpec};
    use crate::sim::writer::{to_bytes, WriterOptions};

    #[test]
    fn serves_every_message_the_project_writes() {
        let spec = SurveySpec {
            duration_s: 3.0,
            ..SurveySpec::default()
        };
        let bytes = to_bytes(WriterOptions::default(), |w| write_survey(w, &spec)).unwrap();
        let mut checked = 0;
        for m in mcap::MessageStream::new(&bytes).unwrap() {
            let m = m.unwrap();
            let d = &m.data[..];
            let schema = m.channel.schema.as_ref().unwrap().name.as_str();
            macro_rules! parsed {
                ($($t:ident),*) => {
                    $( if schema == $t::SCHEMA_NAME { parse::<$t>(d).is_some() } else )* {
                        panic!("{schema}")
                    }
                };
            }
            let ok = crate::for_each_message!(parsed);
            assert!(ok, "{}", String::from_utf8_lossy(d));
            checked += 1;
        }
        assert!(checked > 500);
    }
}
