//! The command decoder under fuzzing: arbitrary byte streams never panic it, frames
//! survive noise around them, and no corrupted frame is read as a command that was not sent.

use proptest::prelude::*;
use tactile_core::command::{
    Command, ControllerChoice, Decoder, Received, Run, TableKind, CHUNK_BYTES, SYNC,
};
use tactile_core::estimator::EstimatorKind;
use tactile_core::tactile::TaxelId;

fn any_command() -> impl Strategy<Value = Command> {
    let run = prop_oneof![
        Just(Run::ForceSteps),
        (any::<u32>(), 0.1f32..600.0)
            .prop_map(|(seed, duration_s)| Run::PseudoRandom { seed, duration_s }),
        Just(Run::Sines),
        Just(Run::StepLoads),
        Just(Run::LowForce),
        (0usize..64).prop_map(|i| Run::Calibration {
            taxel: TaxelId::from_index(i)
        }),
        (0.0f32..200.0).prop_map(|preload_g| Run::Excitation { preload_g }),
    ];
    let table = prop_oneof![Just(TableKind::Calibration), Just(TableKind::Controller)];
    prop_oneof![
        run.prop_map(Command::Run),
        (-10.0f32..200.0).prop_map(|force_g| Command::Hold { force_g }),
        Just(Command::Stop),
        Just(Command::ClearFaults),
        prop_oneof![Just(ControllerChoice::A1), Just(ControllerChoice::Designed)]
            .prop_map(Command::Controller),
        (0usize..EstimatorKind::COUNT).prop_map(|i| Command::Estimator(EstimatorKind::ALL[i])),
        (
            table.clone(),
            any::<u16>(),
            proptest::collection::vec(any::<u8>(), 0..=CHUNK_BYTES)
        )
            .prop_map(|(table, offset, bytes)| {
                let mut data = [0u8; CHUNK_BYTES];
                data[..bytes.len()].copy_from_slice(&bytes);
                Command::TableChunk {
                    table,
                    offset,
                    len: bytes.len() as u8,
                    data,
                }
            }),
        (table, any::<u16>()).prop_map(|(table, len)| Command::LoadTable { table, len }),
    ]
}

fn frame(c: &Command, seq: u16) -> Vec<u8> {
    c.frame(seq).as_bytes().to_vec()
}

/// Everything the decoder reads from `bytes`, with a pause at the end.
fn read(mut bytes: &[u8]) -> Vec<Received> {
    let mut d = Decoder::new();
    let mut out: Vec<Received> = std::iter::from_fn(|| d.read(&mut bytes)).collect();
    d.idle();
    out.extend(std::iter::from_fn(|| d.next_frame()));
    out
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    /// Any bytes: no panic, and whatever is read as a command encodes back to a frame that
    /// reads as the same command.
    #[test]
    fn any_bytes_are_read_without_a_panic(bytes in proptest::collection::vec(any::<u8>(), 0..800)) {
        for r in read(&bytes) {
            if let Ok(c) = r.command {
                prop_assert_eq!(read(&frame(&c, r.seq)), vec![r]);
            }
        }
    }

    /// Commands with noise between them (bytes with no sync byte): every one read, in order.
    #[test]
    fn frames_survive_noise_between_them(
        commands in proptest::collection::vec((any_command(), proptest::collection::vec(any::<u8>(), 0..20)), 1..12),
    ) {
        let mut bytes = Vec::new();
        for (i, (c, noise)) in commands.iter().enumerate() {
            bytes.extend(noise.iter().map(|b| if *b == SYNC { 0 } else { *b }));
            bytes.extend(frame(c, i as u16));
        }
        let got = read(&bytes);
        let sent: Vec<Received> = commands
            .iter()
            .enumerate()
            .map(|(i, (c, _))| Received { seq: i as u16, command: Ok(*c) })
            .collect();
        prop_assert_eq!(got, sent);
    }

    /// One byte of a stream of frames changed: nothing is read that was not sent, and the
    /// frames the change did not touch are all read.
    #[test]
    fn a_corrupted_byte_never_makes_another_command(
        commands in proptest::collection::vec(any_command(), 1..8),
        at in any::<prop::sample::Index>(),
        flip in 1u8..=255,
    ) {
        let frames: Vec<Vec<u8>> = commands.iter().enumerate().map(|(i, c)| frame(c, i as u16)).collect();
        let mut bytes: Vec<u8> = frames.concat();
        let k = at.index(bytes.len());
        bytes[k] ^= flip;
        let got = read(&bytes);
        let mut start = 0;
        let mut hit = usize::MAX;
        for (i, f) in frames.iter().enumerate() {
            if (start..start + f.len()).contains(&k) {
                hit = i;
            }
            start += f.len();
        }
        for r in &got {
            let i = usize::from(r.seq);
            prop_assert!(i < commands.len() && i != hit, "{:?} read; the change hit frame {}", r, hit);
            prop_assert_eq!(r.command, Ok(commands[i]));
        }
        prop_assert!(got.len() + 1 >= commands.len(), "{} of {} read", got.len(), commands.len());
    }
}
