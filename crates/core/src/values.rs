//! Values sized to the MIDI 1.0 specification.
//!
//! Each newtype can only hold what the wire can carry: a [`Channel`] is 4 bits, a
//! [`Note`], a [`Velocity`] and a [`U7`] are 7 bits, a [`U14`] is 14 bits. Constructors
//! that take a wider integer either check (`new`) or mask (`from_bits`), so no value
//! outside the specification can be built.

macro_rules! u7_newtype {
    ($(#[$doc:meta])* $name:ident) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
        pub struct $name(u8);

        impl $name {
            /// The largest value, 127.
            pub const MAX: Self = Self(0x7F);

            /// Returns the value if it fits in 7 bits.
            pub const fn new(value: u8) -> Option<Self> {
                if value <= 0x7F {
                    Some(Self(value))
                } else {
                    None
                }
            }

            /// Keeps the low 7 bits of `value`, as a receiver does with a data byte.
            pub const fn from_bits(value: u8) -> Self {
                Self(value & 0x7F)
            }

            /// The value as a plain integer, 0..=127.
            pub const fn get(self) -> u8 {
                self.0
            }
        }

        impl From<$name> for u8 {
            fn from(value: $name) -> u8 {
                value.0
            }
        }

        impl TryFrom<u8> for $name {
            type Error = InvalidValue;
            fn try_from(value: u8) -> Result<Self, InvalidValue> {
                Self::new(value).ok_or(InvalidValue)
            }
        }

        impl core::fmt::Display for $name {
            fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                core::fmt::Display::fmt(&self.0, f)
            }
        }
    };
}

/// A value did not fit the bits the MIDI specification gives it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct InvalidValue;

impl core::fmt::Display for InvalidValue {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("value out of range for its MIDI field")
    }
}

u7_newtype!(
    /// A MIDI note number, 0..=127 (60 is middle C).
    Note
);
u7_newtype!(
    /// A note velocity, 0..=127. A Note-On with velocity 0 is a Note-Off.
    Velocity
);
u7_newtype!(
    /// Any other 7-bit data value: controller number or value, program, pressure.
    U7
);

/// A MIDI channel, 0..=15 on the wire (shown to people as 1..=16).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct Channel(u8);

impl Channel {
    /// Returns the channel if `value` is 0..=15.
    pub const fn new(value: u8) -> Option<Self> {
        if value <= 0x0F {
            Some(Self(value))
        } else {
            None
        }
    }

    /// The channel held in the low nibble of a status byte.
    pub const fn from_status(status: u8) -> Self {
        Self(status & 0x0F)
    }

    /// The channel as 0..=15.
    pub const fn get(self) -> u8 {
        self.0
    }

    /// This channel's bit in a [`ChannelMask`]-style `u16`.
    pub const fn bit(self) -> u16 {
        crate::bits::bit16(self.0)
    }
}

impl core::fmt::Display for Channel {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        core::fmt::Display::fmt(&self.0, f)
    }
}

/// A 14-bit value made of two 7-bit data bytes, LSB first on the wire (pitch bend, song position).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct U14(u16);

impl U14 {
    /// The centre of a pitch bend, 0x2000.
    pub const CENTER: Self = Self(0x2000);
    /// The largest value, 16383.
    pub const MAX: Self = Self(0x3FFF);

    /// Returns the value if it fits in 14 bits.
    pub const fn new(value: u16) -> Option<Self> {
        if value <= 0x3FFF {
            Some(Self(value))
        } else {
            None
        }
    }

    /// Joins two data bytes as they arrive on the wire: least significant first.
    pub const fn from_lsb_msb(lsb: u8, msb: u8) -> Self {
        Self(((msb as u16 & 0x7F) << 7) | (lsb as u16 & 0x7F))
    }

    /// The value as 0..=16383.
    pub const fn get(self) -> u16 {
        self.0
    }

    /// The value relative to the centre, −8192..=8191, as pitch bend is usually shown.
    pub const fn centered(self) -> i16 {
        self.0 as i16 - 0x2000
    }
}

/// A set of MIDI channels, one bit each (bit 0 is channel 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ChannelMask(pub u16);

impl ChannelMask {
    /// Every channel.
    pub const ALL: Self = Self(0xFFFF);
    /// No channel.
    pub const NONE: Self = Self(0);

    /// Whether `channel` is in the set.
    pub const fn contains(self, channel: Channel) -> bool {
        self.0 & channel.bit() != 0
    }

    /// The set with `channel` added.
    pub const fn with(self, channel: Channel) -> Self {
        Self(self.0 | channel.bit())
    }
}

impl Default for ChannelMask {
    fn default() -> Self {
        Self::ALL
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn u7_rejects_values_with_the_status_bit() {
        assert_eq!(Note::new(128), None);
        assert_eq!(Note::new(127).map(Note::get), Some(127));
        assert_eq!(Velocity::from_bits(0xFF).get(), 0x7F);
    }

    #[test]
    fn u14_joins_lsb_first_and_centres_pitch_bend() {
        assert_eq!(U14::from_lsb_msb(0x00, 0x40), U14::CENTER);
        assert_eq!(U14::from_lsb_msb(0x7F, 0x7F).centered(), 8191);
        assert_eq!(U14::from_lsb_msb(0, 0).centered(), -8192);
    }

    #[test]
    fn channel_comes_from_the_low_nibble() {
        assert_eq!(Channel::from_status(0x9A).get(), 10);
        assert!(ChannelMask::NONE
            .with(Channel::from_status(0x83))
            .contains(Channel::from_status(0x93)));
        assert_eq!(Channel::new(16), None);
    }
}
