//! A board over a debug probe: probe-rs, as a library, attaches to the chip, flashes
//! the firmware if asked, finds the RTT control block the firmware set up, and carries the
//! defmt up-channel 0 and the command down-channel 0 as a [`Transport`]. Nothing here is
//! exercised without a board; what it feeds (`tactile board`'s session, the live decoder) is
//! tested on the QEMU firmware's stream.

use std::io;
use std::path::Path;
use std::time::{Duration, Instant};

use probe_rs::rtt::Rtt;
use probe_rs::{Permissions, Session};
use tactile_decode::transport::Transport;

/// The STM32F407G-DISC1's chip, as probe-rs names it.
pub const F407: &str = "STM32F407VGTx";

/// A chip attached through the first probe found, with its RTT channels.
pub struct Probe {
    session: Session,
    rtt: Rtt,
    /// Whether the stream is at a frame boundary yet (attached to a running board, the first
    /// bytes may be the end of a frame).
    synced: bool,
    buf: Vec<u8>,
}

impl Probe {
    /// Attaches to `chip` through the first probe found; with `flash`, writes that ELF and
    /// resets the chip first. Waits up to two seconds for the firmware's RTT control block.
    pub fn attach(chip: &str, flash: Option<&Path>) -> Result<Probe, String> {
        known_chip(chip)?;
        let probes = probe_rs::probe::list::Lister::new().list_all();
        let Some(first) = probes.first() else {
            return Err("no debug probe found (is the board's ST-LINK plugged in? on Linux, \
                        the probe needs udev rules: https://probe.rs/docs/getting-started/probe-setup/)"
                .into());
        };
        let cannot = |e: &dyn std::fmt::Display| {
            format!("cannot attach to {chip} through {}: {e}", first.identifier)
        };
        let mut session = first
            .open()
            .map_err(|e| cannot(&e))?
            .attach(chip, Permissions::default())
            .map_err(|e| cannot(&e))?;
        let synced = flash.is_some();
        if let Some(elf) = flash {
            probe_rs::flashing::download_file(
                &mut session,
                elf,
                probe_rs::flashing::FormatKind::Elf,
            )
            .map_err(|e| format!("cannot flash {}: {e}", elf.display()))?;
            session
                .core(0)
                .and_then(|mut core| core.reset())
                .map_err(|e| format!("cannot reset {chip} after flashing: {e}"))?;
        }
        let deadline = Instant::now() + Duration::from_secs(2);
        let rtt = loop {
            let mut core = session
                .core(0)
                .map_err(|e| format!("cannot reach {chip}'s core: {e}"))?;
            match Rtt::attach(&mut core) {
                Ok(rtt) => break rtt,
                Err(_) if Instant::now() < deadline => {
                    drop(core);
                    std::thread::sleep(Duration::from_millis(50));
                }
                Err(e) => {
                    return Err(format!(
                        "no RTT control block on {chip} (is the project's firmware running?): {e}"
                    ))
                }
            }
        };
        Ok(Probe {
            session,
            rtt,
            synced,
            buf: vec![0; 16 * 1024],
        })
    }
}

/// Whether probe-rs's built-in chip database has `chip` (checked before looking for a probe:
/// a misspelt chip is said as such).
pub fn known_chip(chip: &str) -> Result<(), String> {
    probe_rs::config::Registry::from_builtin_families()
        .get_target_by_name(chip)
        .map(|_| ())
        .map_err(|e| {
            format!(
                "probe-rs does not know the chip {chip:?} ({e}); the STM32F407G-DISC1's is {F407}"
            )
        })
}

/// The bytes after the first frame delimiter (rzCOBS frames end in 0x00), or none if `bytes`
/// holds none: where a stream joined mid-frame becomes decodable.
pub fn after_first_delimiter(bytes: &[u8]) -> Option<&[u8]> {
    bytes
        .iter()
        .position(|&b| b == 0)
        .and_then(|i| bytes.get(i + 1..))
}

impl Transport for Probe {
    fn receive(&mut self) -> io::Result<Option<Vec<u8>>> {
        let mut core = self.session.core(0).map_err(io::Error::other)?;
        let up = self
            .rtt
            .up_channel(0)
            .ok_or_else(|| io::Error::other("the firmware has no RTT up-channel 0"))?;
        let n = up
            .read(&mut core, &mut self.buf)
            .map_err(io::Error::other)?;
        let got = self.buf.get(..n).unwrap_or(&[]);
        let bytes = if self.synced {
            got.to_vec()
        } else {
            match after_first_delimiter(got) {
                Some(rest) => {
                    self.synced = true;
                    rest.to_vec()
                }
                None => Vec::new(),
            }
        };
        if n == 0 {
            // Nothing new: poll again shortly (the board writes about 10 KB/s).
            std::thread::sleep(Duration::from_millis(5));
        }
        Ok(Some(bytes))
    }

    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        let deadline = Instant::now() + Duration::from_secs(1);
        let mut rest = bytes;
        while !rest.is_empty() {
            let mut core = self.session.core(0).map_err(io::Error::other)?;
            let down = self.rtt.down_channel(0).ok_or_else(|| {
                io::Error::other("the firmware has no RTT down-channel 0: an older build?")
            })?;
            let n = down.write(&mut core, rest).map_err(io::Error::other)?;
            rest = rest.get(n..).unwrap_or(&[]);
            if n == 0 {
                if Instant::now() > deadline {
                    return Err(io::Error::other(
                        "the board takes no commands (its down-channel stays full)",
                    ));
                }
                drop(core);
                std::thread::sleep(Duration::from_millis(2));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_boards_chip_is_known_and_a_misspelt_one_is_said_so() {
        assert_eq!(known_chip(F407), Ok(()));
        let e = known_chip("STM32F407XX").unwrap_err();
        assert!(e.contains("STM32F407XX") && e.contains(F407), "{e}");
    }

    #[test]
    fn a_stream_joined_mid_frame_starts_after_the_first_delimiter() {
        assert_eq!(
            after_first_delimiter(&[7, 9, 0, 1, 2, 0]),
            Some(&[1, 2, 0][..])
        );
        assert_eq!(after_first_delimiter(&[0]), Some(&[][..]));
        assert_eq!(after_first_delimiter(&[3, 4]), None);
    }
}
