//! Test support: a SoundFont written here, whose sound starts at full level on its first
//! sample, so a strike's onset in the audio is the strike's own sample (an installed font's
//! samples begin with tens to hundreds of samples of silence, which differ by note).

use std::sync::Arc;

use rustysynth::SoundFont;

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

/// A SoundFont 2 with one preset (bank 0, program 0) of one sample: a square wave of ±0.5
/// full scale, 100 samples a period, looped, recorded at `rate` Hz with root key 60. Its first
/// sample is at +0.5, and its volume envelope has no delay and no attack: a voice's first
/// output sample is already far above −100 dBFS.
pub fn square_font(rate: u32) -> Arc<SoundFont> {
    font(rate, true)
}

/// The same with the SF2 default volume envelope (a delay of −12 000 timecents, 1 ms, and an
/// attack as long): its voices begin 41 samples after they start at 44.1 kHz.
pub fn square_font_with_default_envelope(rate: u32) -> Arc<SoundFont> {
    font(rate, false)
}

fn font(rate: u32, instant: bool) -> Arc<SoundFont> {
    let period = 100usize;
    let len = 20 * period;
    let mut wave: Vec<i16> = (0..len)
        .map(|i| {
            if i % period < period / 2 {
                16384
            } else {
                -16384
            }
        })
        .collect();
    wave.extend(std::iter::repeat_n(0, 46)); // the 46 zero samples the format asks after each
    let smpl: Vec<u8> = wave.iter().flat_map(|s| s.to_le_bytes()).collect();

    let mut phdr = name20("square");
    phdr.extend_from_slice(&[0, 0, 0, 0, 0, 0]); // preset 0, bank 0, bag 0
    phdr.extend_from_slice(&[0; 12]);
    phdr.extend_from_slice(&name20("EOP"));
    phdr.extend_from_slice(&[0, 0, 0, 0, 1, 0]);
    phdr.extend_from_slice(&[0; 12]);
    let pbag = [0u8, 0, 0, 0, 1, 0, 0, 0];
    let pmod = [0u8; 10];
    let mut pgen = Vec::new();
    pgen.extend_from_slice(&41u16.to_le_bytes()); // instrument
    pgen.extend_from_slice(&0u16.to_le_bytes());
    pgen.extend_from_slice(&[0; 4]);
    let mut inst = name20("square");
    inst.extend_from_slice(&0u16.to_le_bytes());
    inst.extend_from_slice(&name20("EOI"));
    inst.extend_from_slice(&1u16.to_le_bytes());
    let gens: u8 = if instant { 4 } else { 2 };
    let ibag = [0u8, 0, 0, 0, gens, 0, 0, 0];
    let imod = [0u8; 10];
    let mut igen = Vec::new();
    // delayVolEnv and attackVolEnv at their shortest (-32768 timecents: nothing): the SF2
    // default, -12000 (1 ms), delays every voice by 41 samples at 44.1 kHz in rustysynth.
    for generator in [33u16, 34].into_iter().filter(|_| instant) {
        igen.extend_from_slice(&generator.to_le_bytes());
        igen.extend_from_slice(&0x8000u16.to_le_bytes());
    }
    igen.extend_from_slice(&54u16.to_le_bytes()); // sampleModes: loop continuously
    igen.extend_from_slice(&1u16.to_le_bytes());
    igen.extend_from_slice(&53u16.to_le_bytes()); // sampleID 0
    igen.extend_from_slice(&0u16.to_le_bytes());
    igen.extend_from_slice(&[0; 4]);
    let mut shdr = name20("square");
    for v in [0u32, len as u32, 0, len as u32, rate] {
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
