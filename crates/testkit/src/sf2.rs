//! A SoundFont 2 written here, for the tests of orch-render and orch-calibrate: one preset
//! (bank 0, program 0) of one instrument playing one mono sample on
//! every key, root key 60.

use std::sync::Arc;

use orch_render::SoundFont;

/// SF2 generator numbers used by the tests' fonts.
pub const DELAY_VOL_ENV: u16 = 33;
pub const ATTACK_VOL_ENV: u16 = 34;
pub const RELEASE_VOL_ENV: u16 = 38;
pub const SAMPLE_MODES: u16 = 54;
const INSTRUMENT: u16 = 41;
const SAMPLE_ID: u16 = 53;
/// The shortest time a timecents generator takes (-32 768: none).
pub const NO_TIME: i16 = i16::MIN;

fn chunk(id: &[u8; 4], body: &[u8]) -> Vec<u8> {
    let mut v = id.to_vec();
    v.extend_from_slice(&(body.len() as u32).to_le_bytes());
    v.extend_from_slice(body);
    if body.len() % 2 == 1 {
        v.push(0);
    }
    v
}

fn list(kind: &[u8; 4], chunks: &[Vec<u8>]) -> Vec<u8> {
    let mut body = kind.to_vec();
    for c in chunks {
        body.extend_from_slice(c);
    }
    chunk(b"LIST", &body)
}

fn name20(name: &str) -> Vec<u8> {
    let mut v = name.as_bytes().to_vec();
    v.resize(20, 0);
    v
}

fn generator(out: &mut Vec<u8>, number: u16, amount: i16) {
    out.extend_from_slice(&number.to_le_bytes());
    out.extend_from_slice(&amount.to_le_bytes());
}

/// The font of `wave` recorded at `rate` Hz (its loop, if `generators` loops it, the whole
/// sample), its instrument zone carrying `generators` (number, amount) before the sample.
pub fn one_sample(wave: &[i16], rate: u32, generators: &[(u16, i16)]) -> Arc<SoundFont> {
    let len = wave.len() as u32;
    let mut data = wave.to_vec();
    data.extend(std::iter::repeat_n(0, 46)); // the 46 zero samples the format asks after each
    let smpl: Vec<u8> = data.iter().flat_map(|s| s.to_le_bytes()).collect();

    let mut phdr = name20("sample");
    phdr.extend_from_slice(&[0, 0, 0, 0, 0, 0]); // preset 0, bank 0, bag 0
    phdr.extend_from_slice(&[0; 12]);
    phdr.extend_from_slice(&name20("EOP"));
    phdr.extend_from_slice(&[0, 0, 0, 0, 1, 0]);
    phdr.extend_from_slice(&[0; 12]);
    let pbag = [0u8, 0, 0, 0, 1, 0, 0, 0];
    let pmod = [0u8; 10];
    let mut pgen = Vec::new();
    generator(&mut pgen, INSTRUMENT, 0);
    pgen.extend_from_slice(&[0; 4]);
    let mut inst = name20("sample");
    inst.extend_from_slice(&0u16.to_le_bytes());
    inst.extend_from_slice(&name20("EOI"));
    inst.extend_from_slice(&1u16.to_le_bytes());
    let gens = u16::try_from(generators.len() + 1).expect("a few generators");
    let mut ibag = vec![0u8, 0, 0, 0];
    ibag.extend_from_slice(&gens.to_le_bytes());
    ibag.extend_from_slice(&[0, 0]);
    let imod = [0u8; 10];
    let mut igen = Vec::new();
    for &(number, amount) in generators {
        generator(&mut igen, number, amount);
    }
    generator(&mut igen, SAMPLE_ID, 0);
    igen.extend_from_slice(&[0; 4]);
    let mut shdr = name20("sample");
    for v in [0u32, len, 0, len, rate] {
        shdr.extend_from_slice(&v.to_le_bytes());
    }
    shdr.extend_from_slice(&[60, 0, 0, 0, 1, 0]); // root 60, no correction, no link, mono
    shdr.extend_from_slice(&name20("EOS"));
    shdr.extend_from_slice(&[0; 26]);

    let info = list(
        b"INFO",
        &[
            chunk(b"ifil", &[2, 0, 1, 0]),
            chunk(b"isng", b"EMU8000\0"),
            chunk(b"INAM", b"orch test\0"),
        ],
    );
    let sdta = list(b"sdta", &[chunk(b"smpl", &smpl)]);
    let pdta = list(
        b"pdta",
        &[
            chunk(b"phdr", &phdr),
            chunk(b"pbag", &pbag),
            chunk(b"pmod", &pmod),
            chunk(b"pgen", &pgen),
            chunk(b"inst", &inst),
            chunk(b"ibag", &ibag),
            chunk(b"imod", &imod),
            chunk(b"igen", &igen),
            chunk(b"shdr", &shdr),
        ],
    );
    let mut body = b"sfbk".to_vec();
    body.extend_from_slice(&info);
    body.extend_from_slice(&sdta);
    body.extend_from_slice(&pdta);
    let riff = chunk(b"RIFF", &body);
    Arc::new(SoundFont::new(&mut riff.as_slice()).expect("the test font parses"))
}
