//! How the host reaches a board: the defmt stream up, command bytes down. `tactile
//! board` works through [`Transport`] alone, so it is tested end to end on the QEMU firmware
//! ([`Qemu`]) and on a saved log ([`Replay`]); a probe's RTT (probe-rs) is one more
//! implementation.

use std::io::{self, Read};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{self, Receiver};

/// A board's two byte streams.
pub trait Transport {
    /// The bytes that arrived since the last call (possibly none); `None` once the board's
    /// stream has ended (QEMU exited, a replayed log is at its end).
    fn receive(&mut self) -> io::Result<Option<Vec<u8>>>;
    /// Sends command bytes (`tactile_core::command` frames) down to the board.
    fn send(&mut self, bytes: &[u8]) -> io::Result<()>;
}

/// A saved log replayed in pieces, as a live stream would bring it.
pub struct Replay {
    bytes: Vec<u8>,
    at: usize,
    piece: usize,
}

impl Replay {
    /// `bytes` given out `piece` bytes at a time.
    pub fn new(bytes: Vec<u8>, piece: usize) -> Replay {
        Replay {
            bytes,
            at: 0,
            piece: piece.max(1),
        }
    }
}

impl Transport for Replay {
    fn receive(&mut self) -> io::Result<Option<Vec<u8>>> {
        if self.at >= self.bytes.len() {
            return Ok(None);
        }
        let end = (self.at + self.piece).min(self.bytes.len());
        let piece = self.bytes[self.at..end].to_vec();
        self.at = end;
        Ok(Some(piece))
    }
    fn send(&mut self, _: &[u8]) -> io::Result<()> {
        Err(io::Error::new(
            io::ErrorKind::Unsupported,
            "a replayed log takes no commands",
        ))
    }
}

/// The QEMU firmware's command session (`session=commands`): the commands go in as its
/// script, each at the board tick it is due (QEMU reads the script at start, so there is
/// nothing to send once it runs), and its defmt output comes up as it is written.
pub struct Qemu {
    child: Child,
    rx: Receiver<Vec<u8>>,
    done: bool,
}

/// The QEMU command that runs `elf` on the netduinoplus2 model: deterministic instruction
/// counting (`-icount shift=0`: one instruction per virtual nanosecond; `sleep=off`: WFI jumps
/// to the next interrupt), semihosting on, the defmt bytes on stdout.
pub fn qemu_command(elf: &Path) -> Command {
    let mut command = Command::new("qemu-system-arm");
    command
        .args([
            "-machine",
            "netduinoplus2",
            "-nographic",
            "-monitor",
            "none",
        ])
        .args(["-serial", "none", "-icount", "shift=0,align=off,sleep=off"])
        .args(["-semihosting-config", "enable=on,target=native", "-kernel"])
        .arg(elf);
    command
}

/// A command script as the QEMU firmware reads it (`session=commands script=PATH`): entries of
/// (board tick: u32 LE, length: u16 LE, the bytes due at that tick).
pub fn script_bytes(script: &[(u32, Vec<u8>)]) -> io::Result<Vec<u8>> {
    let mut bytes = Vec::new();
    for (tick, b) in script {
        let len = u16::try_from(b.len()).map_err(|_| {
            io::Error::new(io::ErrorKind::InvalidInput, "a script entry over 64 KiB")
        })?;
        bytes.extend(tick.to_le_bytes());
        bytes.extend(len.to_le_bytes());
        bytes.extend(b);
    }
    Ok(bytes)
}

impl Qemu {
    /// Starts `elf` under QEMU's netduinoplus2 with `script` (board tick, command bytes), which
    /// it writes to `script_path`.
    pub fn start(elf: &Path, script: &[(u32, Vec<u8>)], script_path: &Path) -> io::Result<Qemu> {
        std::fs::write(script_path, script_bytes(script)?)?;
        let mut child = qemu_command(elf)
            .arg("-append")
            .arg(format!("session=commands script={}", script_path.display()))
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()?;
        let mut stdout = child
            .stdout
            .take()
            .ok_or_else(|| io::Error::other("QEMU's output is not piped"))?;
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            let mut buf = vec![0u8; 64 * 1024];
            while let Ok(n) = stdout.read(&mut buf) {
                if n == 0 || tx.send(buf[..n].to_vec()).is_err() {
                    break;
                }
            }
        });
        Ok(Qemu {
            child,
            rx,
            done: false,
        })
    }
}

impl Transport for Qemu {
    fn receive(&mut self) -> io::Result<Option<Vec<u8>>> {
        if self.done {
            return Ok(None);
        }
        let mut out = Vec::new();
        match self.rx.recv_timeout(std::time::Duration::from_millis(50)) {
            Ok(b) => out.extend(b),
            Err(mpsc::RecvTimeoutError::Timeout) => return Ok(Some(out)),
            Err(mpsc::RecvTimeoutError::Disconnected) => {
                self.done = true;
                let status = self.child.wait()?;
                if !status.success() {
                    return Err(io::Error::other(format!("QEMU exited with {status}")));
                }
                return Ok(None);
            }
        }
        while let Ok(b) = self.rx.try_recv() {
            out.extend(b);
        }
        Ok(Some(out))
    }
    fn send(&mut self, _: &[u8]) -> io::Result<()> {
        Err(io::Error::new(
            io::ErrorKind::Unsupported,
            "QEMU reads its commands from the script at start",
        ))
    }
}

impl Drop for Qemu {
    fn drop(&mut self) {
        if !self.done {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}
