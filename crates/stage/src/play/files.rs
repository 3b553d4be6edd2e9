//! The files a play leaves (`--writes`, `--notes`): created before anything plays, so a
//! path that cannot be written is refused at once, and written when the play has ended.

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use orch_perform::Tempo;
use orch_seq::Song;

use super::{Leaves, PlayError};
use crate::session::Ended;

/// A file created, to write when the play has ended.
struct Leaving {
    path: PathBuf,
    file: BufWriter<File>,
}

/// The files a play leaves.
pub(super) struct Files {
    writes: Option<Leaving>,
    notes: Option<Leaving>,
}

impl Files {
    /// Creates the board writes' file and the account's, those given, in that order.
    pub(super) fn create<E>(
        writes: Option<&Path>,
        notes: Option<&Path>,
    ) -> Result<Self, PlayError<E>> {
        Ok(Self {
            writes: writes.map(|p| open(p, Leaves::Writes)).transpose()?,
            notes: notes.map(|p| open(p, Leaves::Notes)).transpose()?,
        })
    }

    /// Whether the song is needed at the end (the account's bars and beats).
    pub(super) fn wants_song(&self) -> bool {
        self.notes.is_some()
    }

    /// Writes the board writes, then the account (of `song`, played at `tempo`).
    pub(super) fn write<E>(
        &mut self,
        song: Option<&Song>,
        ended: &[Ended],
        tempo: Tempo,
    ) -> Result<(), PlayError<E>> {
        if let Some(w) = self.writes.as_mut() {
            crate::account::write_board_writes(&mut w.file, ended)
                .map_err(|e| failed(w, Leaves::Writes, e))?;
        }
        if let (Some(n), Some(song)) = (self.notes.as_mut(), song) {
            crate::account::write_accounts(&mut n.file, song, ended, tempo)
                .map_err(|e| failed(n, Leaves::Notes, e))?;
        }
        Ok(())
    }
}

fn open<E>(path: &Path, leaves: Leaves) -> Result<Leaving, PlayError<E>> {
    let file = File::create(path).map_err(|source| PlayError::File {
        leaves,
        path: path.to_path_buf(),
        source,
        created: true,
    })?;
    Ok(Leaving {
        path: path.to_path_buf(),
        file: BufWriter::new(file),
    })
}

fn failed<E>(l: &Leaving, leaves: Leaves, source: std::io::Error) -> PlayError<E> {
    PlayError::File {
        leaves,
        path: l.path.clone(),
        source,
        created: false,
    }
}
