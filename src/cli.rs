//! The command line.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};

/// Make MIDI-driven solenoid instruments play.
#[derive(Parser, Debug)]
#[command(name = "orch", version, about, propagate_version = true)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Decode raw MIDI bytes and print one message per line, then the counters.
    Decode(DecodeArgs),
    /// Run raw MIDI bytes through the interpreter and the safety guard, and print every board
    /// write as it would go on the bus.
    Interpret(InterpretArgs),
    /// Play a Standard MIDI File on the virtual robot, live, and report how well it went.
    Play(PlayArgs),
    /// Say whether the robot can play a MIDI file, and what will go wrong, without playing it.
    Analyze(AnalyzeArgs),
    /// Print the default robot configuration (robot.toml), commented.
    Config(ConfigArgs),
    /// Follow a conductor's baton (a red LED at its tip) in a video and print each beat.
    Baton(BatonArgs),
    /// Play live MIDI on the robot: bytes in (serial, raw MIDI, UDP, stdin), the interpreter
    /// and its guard, finger boards out (the virtual robot or I2C), the stream passed on.
    Run(RunArgs),
    /// Play a Standard MIDI File live, following a conductor: a baton video, tap tempo,
    /// MIDI clock or OSC.
    Conduct(ConductArgs),
    /// Calibrate a robot by ear: write the calibration score (--score), or read a recording
    /// of it (--wav), or play and record it live (--out, --mic), and print the calibrated
    /// robot.toml (or, with --json, the measurements).
    Calibrate(CalibrateArgs),
    /// Render the virtual robot's performance of a MIDI file (or, with --score, the file
    /// itself) as sound, through a SoundFont, to a WAV file.
    Render(RenderArgs),
    /// Serve one web page to pick, analyse and play songs on the robot, live, from a phone
    /// (see the book's "The web page").
    Serve(ServeArgs),
}

#[derive(Args, Debug)]
pub struct ServeArgs {
    /// The robot's configuration (see `orch config`); the thesis's robot if not given.
    #[arg(long, value_name = "FILE")]
    pub robot: Option<PathBuf>,
    /// Where to play, as many times as there are robots (as `orch play --out`): sim (the
    /// default), serial:DEVICE, rawmidi:DEVICE, udp:HOST:PORT, i2c:DEVICE, each optionally
    /// followed by :ch=LIST.
    #[arg(long = "out", value_name = "OUT")]
    pub outs: Vec<String>,
    /// A folder of MIDI files (.mid, .midi) the page offers to pick from; none if not given.
    #[arg(long, value_name = "DIR")]
    pub library: Option<PathBuf>,
    /// The address to listen on. On loopback (the default) anyone on this machine may use
    /// the page; on any other address (0.0.0.0 for all) a random token is required, printed
    /// at start in the page's URL. Port 0 takes a free port (the URL says which).
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:8080")]
    pub listen: std::net::SocketAddr,
    /// Send every message at its score time instead of early by the key's mechanical delay.
    #[arg(long)]
    pub no_compensation: bool,
    /// Log what the outputs do on standard error; without it only warnings.
    #[arg(long, short)]
    pub verbose: bool,
    /// Show and steer the Ableton Link session on the network on the page (built with the
    /// `link` feature): its peers and tempo, and Start, Stop and a tempo for it.
    #[arg(long)]
    pub link: bool,
}

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// The Standard MIDI File.
    pub file: PathBuf,
    /// The WAV file to write (stereo, 32-bit float).
    #[arg(short = 'o', long = "out", value_name = "OUT.wav")]
    pub out: PathBuf,
    /// The robot's configuration (see `orch config`); the thesis's robot if not given.
    #[arg(long, value_name = "FILE")]
    pub robot: Option<PathBuf>,
    /// Render the file itself (every note at its score time and velocity) instead of the
    /// robot's performance, to listen side by side.
    #[arg(long)]
    pub score: bool,
    /// The SoundFont 2 file; without it, one installed by a Debian package
    /// (fluid-soundfont-gm, timgm6mb-soundfont) in /usr/share/sounds/sf2.
    #[arg(long, value_name = "SF2")]
    pub soundfont: Option<PathBuf>,
    /// Samples a second.
    #[arg(long, default_value_t = 44_100, value_name = "HZ")]
    pub rate: u32,
}

/// Where the bytes come from and how they are written.
#[derive(Args, Debug)]
pub struct Source {
    /// File of raw MIDI bytes; `-` or nothing reads standard input.
    #[arg(value_name = "FILE|-")]
    pub file: Option<PathBuf>,
    /// The input is hex text: pairs of hex digits, whitespace optional, `#` starts a comment.
    #[arg(long)]
    pub hex: bool,
    /// Print one JSON object per line instead of text.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args, Debug)]
pub struct DecodeArgs {
    #[command(flatten)]
    pub source: Source,
}

#[derive(Args, Debug)]
pub struct InterpretArgs {
    #[command(flatten)]
    pub source: Source,
    /// The robot's configuration (see `orch config`); the thesis's robot if not given.
    #[arg(long, value_name = "FILE")]
    pub robot: Option<PathBuf>,
    /// Turn the safety guard off to show the bare note-to-finger mapping, or on whatever the
    /// robot file says (the flag wins over `guard.enabled`, with a warning). Without it: as
    /// the robot file says (on unless it has `enabled = false`).
    #[arg(long, value_enum)]
    pub guard: Option<OnOff>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum OnOff {
    On,
    Off,
}

#[derive(Args, Debug)]
pub struct PlayArgs {
    /// The Standard MIDI File.
    pub file: PathBuf,
    /// The robot's configuration (see `orch config`); the thesis's robot if not given.
    #[arg(long, value_name = "FILE")]
    pub robot: Option<PathBuf>,
    /// Render on the virtual clock, as fast as possible, instead of in real time.
    #[arg(long)]
    pub fast: bool,
    /// Print the report as one JSON object.
    #[arg(long)]
    pub json: bool,
    /// Send every message at its score time instead of early by the key's mechanical delay.
    #[arg(long)]
    pub no_compensation: bool,
    /// Tempo factor: 2 plays twice as fast, 0.5 half as fast.
    #[arg(long, default_value_t = 1.0, value_name = "FACTOR")]
    pub tempo: f64,
    /// Start at this bar (from 1, as the view counts bars); the notes before it are counted
    /// skipped.
    #[arg(long, value_name = "BAR")]
    pub from: Option<u32>,
    /// No live terminal view (it is off anyway when the output is not a terminal).
    #[arg(long)]
    pub no_view: bool,
    /// Where to play, as many times as there are robots: sim (the default), serial:DEVICE,
    /// rawmidi:DEVICE, udp:HOST:PORT, rtpmidi:HOST:PORT (an RTP-MIDI session orch begins),
    /// i2c:DEVICE or (built with the `alsa` feature)
    /// alsa:CLIENT:PORT, each optionally followed by :ch=LIST (channels 1-16, e.g. :ch=1 or
    /// :ch=2,4-6) to give it only those channels.
    #[arg(long = "out", value_name = "OUT")]
    pub outs: Vec<String>,
    /// Log what the outputs do (reconnections, retries) on standard error; without it only
    /// warnings (a device or a board lost, and back).
    #[arg(long)]
    pub verbose: bool,
    /// Write every board write of every robot to FILE, one JSON object a line:
    /// {"out":OUT,"t_us":T,"address":A,"outputs":O}; `t_us` is when the write completed on the
    /// performance's clock, `outputs` the 16 pins the board drives after it. For a MIDI output
    /// these are its virtual copy's writes, at the far end of the line.
    #[arg(long, value_name = "FILE")]
    pub writes: Option<PathBuf>,
    /// Write the note-by-note account to FILE: one JSON object a line for every note of the
    /// file, in score order (see the book's "JSON formats"); with several outputs, each robot's
    /// in turn, with its "out".
    #[arg(long, value_name = "FILE")]
    pub notes: Option<PathBuf>,
    /// Join the Ableton Link session on the network (built with the `link` feature): wait for
    /// it to play, come in on its bar line (a bar of the file's first time signature), and
    /// follow its tempo (a score quarter note is one session beat) until the file ends or the
    /// session stops.
    #[arg(long, conflicts_with_all = ["fast", "from"])]
    pub link: bool,
    /// With --link: start the session if nobody has within a second.
    #[arg(long, requires = "link")]
    pub start: bool,
}

#[derive(Args, Debug)]
pub struct AnalyzeArgs {
    /// The Standard MIDI File.
    pub file: PathBuf,
    /// The robot's configuration (see `orch config`); the thesis's robot if not given.
    #[arg(long, value_name = "FILE")]
    pub robot: Option<PathBuf>,
    /// Print the report as one JSON object.
    #[arg(long)]
    pub json: bool,
    /// Tempo factor: 2 plays twice as fast, 0.5 half as fast.
    #[arg(long, default_value_t = 1.0, value_name = "FACTOR")]
    pub tempo: f64,
    /// Write the note-by-note account to FILE: one JSON object a line for every note of the
    /// file, in score order (see the book's "JSON formats").
    #[arg(long, value_name = "FILE")]
    pub notes: Option<PathBuf>,
    /// Write a piano roll of the performance to FILE as SVG: the score's notes as outlines,
    /// the robot's strikes as fills, coloured by outcome (see the book's "Analyze, the roll,
    /// render").
    #[arg(long, value_name = "FILE")]
    pub svg: Option<PathBuf>,
}

#[derive(Args, Debug)]
#[command(group(clap::ArgGroup::new("mode").required(true).args(["score", "wav", "mic"])))]
pub struct CalibrateArgs {
    /// Write the calibration score to this Standard MIDI File: the sync figure, then every
    /// key struck alone at each velocity level, one strike a second. Play it on the robot
    /// with `orch play CAL.mid --no-compensation --out ...` and record it.
    #[arg(long, value_name = "CAL.mid")]
    pub score: Option<PathBuf>,
    /// Read a recording of the score (WAV: 16/24-bit integer or 32-bit float, 16-192 kHz)
    /// and print the calibrated robot.toml.
    #[arg(long, value_name = "REC.wav", conflicts_with = "score")]
    pub wav: Option<PathBuf>,
    /// Play the score on the robot (--out) and record it at once from this ALSA capture
    /// device (such as default or plughw:CARD=Mic,DEV=0; `arecord -L` lists them), then
    /// print the calibrated robot.toml. Built with the `mic` feature.
    #[arg(long, value_name = "DEVICE", requires = "out")]
    pub mic: Option<String>,
    /// With --mic: the robot to play the score on, as `orch play --out` takes it
    /// (serial:DEVICE, rawmidi:DEVICE, udp:HOST:PORT, i2c:DEVICE, sim).
    #[arg(long, value_name = "OUT", conflicts_with_all = ["score", "wav"])]
    pub out: Option<String>,
    /// With --mic: also write the recording to this WAV file (32-bit float, from the
    /// score's start), to analyse again with --wav.
    #[arg(long, value_name = "REC.wav", conflicts_with_all = ["score", "wav"])]
    pub keep: Option<PathBuf>,
    /// The robot's configuration (see `orch config`); the thesis's robot if not given.
    #[arg(long, value_name = "FILE")]
    pub robot: Option<PathBuf>,
    /// Velocity levels per key, spread over 1..=127 (give the recording's analysis the
    /// same number as its score).
    #[arg(long, value_name = "N", default_value_t = 4)]
    pub levels: u32,
    /// One key's true press delay at full power, NOTE=MS (such as 60=14.5): it fixes the
    /// microphone's unknown latency. Without it, delays are relative to the robot file's
    /// press_delay for middle C.
    #[arg(long, value_name = "NOTE=MS", conflicts_with = "score")]
    pub anchor: Option<String>,
    /// Print the measurements as JSON instead of robot.toml.
    #[arg(long, conflicts_with = "score")]
    pub json: bool,
}

#[derive(Args, Debug)]
pub struct BatonArgs {
    /// The video: a `.y4m` file, a folder of numbered PNG frames (needs --fps), or anything
    /// ffmpeg reads (when ffmpeg is installed).
    pub video: PathBuf,
    /// Frames per second: needed for a folder of PNGs; overrides the video's own rate.
    #[arg(long, value_name = "N")]
    pub fps: Option<f64>,
    /// One JSON object a line: {"t_ms":T,"bpm":B,"x":X,"y":Y}.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args, Debug)]
pub struct RunArgs {
    /// Where the MIDI bytes come from: serial:DEVICE (a DIN line, 31250 baud),
    /// rawmidi:DEVICE (or any file or FIFO), udp:PORT (datagrams on loopback), udp:HOST:PORT,
    /// rtpmidi:PORT or rtpmidi:NAME@PORT (an RTP-MIDI session answered on control port PORT,
    /// data PORT+1, under NAME),
    /// a dash for standard input, or (built with the `alsa` feature) alsa: (a sequencer port
    /// of orch's own to connect to) or alsa:CLIENT:PORT (that source, subscribed). A serial
    /// or raw MIDI device that goes away is opened again when it comes back.
    #[arg(long = "in", value_name = "IN")]
    pub input: String,
    /// The robot: sim (the virtual robot) or i2c:DEVICE (PCA9555 finger boards).
    #[arg(long, value_name = "OUT", default_value = "sim")]
    pub out: String,
    /// Pass the input on to a MIDI output (serial:, rawmidi:, udp:HOST:PORT), whole or only
    /// some channels (:ch=LIST), re-encoded message by message; as many as wanted.
    #[arg(long, value_name = "OUT")]
    pub thru: Vec<String>,
    /// The robot's configuration (see `orch config`); the thesis's robot if not given.
    /// SIGHUP reads it again.
    #[arg(long, value_name = "FILE")]
    pub robot: Option<PathBuf>,
    /// Print every board write as `orch interpret --json` does, t_us from the first input byte.
    #[arg(long)]
    pub json: bool,
    /// No live terminal view (it is off anyway when the output is not a terminal).
    #[arg(long)]
    pub no_view: bool,
    /// A counters line on standard error every second of input and at the end (SIGUSR1 asks
    /// for one at any time); what the outputs do.
    #[arg(long)]
    pub verbose: bool,
}

#[derive(Args, Debug)]
pub struct ConductArgs {
    /// The Standard MIDI File.
    pub file: PathBuf,
    /// The conductor: baton:VIDEO (a baton with a red LED, the video's start at the score's),
    /// camera:DEVICE (the same baton seen live by a V4L2 camera such as /dev/video0; built
    /// with the `camera` feature), tap (the space bar in the live view), midi-clock:IN (raw MIDI bytes with clock 0xF8,
    /// Start, Stop, Continue, Song Position: IN is `-` for standard input, a file, FIFO or
    /// device, or udp:PORT), or osc:PORT (`/orch/tempo f`, `/orch/beat`). UDP listens on 127.0.0.1
    /// unless HOST:PORT is given.
    #[arg(long, value_name = "SOURCE")]
    pub source: String,
    /// Follow the conductor's rate only (immediate), or also pull the phase toward each beat.
    /// Either way the tempo is measured from the beats' times: a sustained change is taken
    /// at its second beat, a single odd beat (missed, invented, a fermata) never.
    #[arg(long, value_enum, default_value_t = FollowMode::Phase)]
    pub follow: FollowMode,
    /// Start at this bar (from 1, as the view counts bars); the notes before it are counted
    /// skipped.
    #[arg(long, value_name = "BAR")]
    pub from: Option<u32>,
    /// The robot's configuration (see `orch config`); the thesis's robot if not given.
    #[arg(long, value_name = "FILE")]
    pub robot: Option<PathBuf>,
    /// Print the report as one JSON object.
    #[arg(long)]
    pub json: bool,
    /// Send every message at its score time instead of early by the key's mechanical delay.
    #[arg(long)]
    pub no_compensation: bool,
    /// No live terminal view (it is off anyway when the output is not a terminal).
    #[arg(long)]
    pub no_view: bool,
    /// Where to play, as `orch play --out`.
    #[arg(long = "out", value_name = "OUT")]
    pub outs: Vec<String>,
    /// Log what the outputs and the source do on standard error.
    #[arg(long)]
    pub verbose: bool,
    /// Lead the Ableton Link session on the network (built with the `link` feature): start it
    /// for bar one, a second or so from now, where the performance starts, and publish the
    /// tempo and phase the performance follows, so that robots on other hosts waiting with
    /// `orch play --link` come in together and follow this conductor; the session stops when
    /// the performance ends.
    #[arg(long, conflicts_with = "from")]
    pub link: bool,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum FollowMode {
    Immediate,
    Phase,
}

/// `orch config`.
#[derive(Debug, clap::Args)]
pub struct ConfigArgs {
    /// The kind of finger boards: pca9555 (on/off, the thesis's; tca9555 is the same) or
    /// pca9685 (PWM: velocity as strike strength), four of them for the 61-key robot.
    #[arg(long, value_name = "KIND", default_value = "pca9555", value_parser = ["pca9555", "tca9555", "pca9685"])]
    pub boards: String,
    /// The instrument: piano (the thesis's 61-key robot), drums (a General MIDI kit on
    /// channel 10: kick, snare, hi-hat and its pedal, three toms, crash, ride),
    /// glockenspiel (30 bars, G5 to C8) or recorder (a soprano recorder's valve and fingers,
    /// C5 to D7, one note at a time).
    #[arg(long, value_name = "NAME", default_value = "piano", value_parser = ["piano", "drums", "glockenspiel", "recorder"])]
    pub instrument: String,
}
