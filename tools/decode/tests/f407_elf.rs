//! The STM32F407G-DISC1 firmware: builds it (`cargo fw-f407`, and with the designed controller's
//! table, `cargo fw-f407-designed`) and checks each ELF: the vector
//! table at the start of flash, the RTT control block, the defmt table, and flash and static
//! RAM against the budget. Ignored in plain `cargo test` (a second target's build);
//! `scripts/test-all.sh` runs it with `--ignored`.

mod common;
use common::build_firmware;

use object::{Object, ObjectSection, ObjectSymbol};

const FLASH: std::ops::Range<u64> = 0x0800_0000..0x0810_0000;
const RAM: std::ops::Range<u64> = 0x2000_0000..0x2002_0000;
/// The core-coupled RAM (memory.x's CCMRAM): the command port lives there.
const CCM: std::ops::Range<u64> = 0x1000_0000..0x1001_0000;
const FLASH_BUDGET: u64 = 64 * 1024;
/// The designed controller's build carries its table (348 B), its loop and the table's checks
/// on top of the build a user types: 2 KiB more (the chip has 1 MiB).
const DESIGNED_FLASH_BUDGET: u64 = FLASH_BUDGET + 2 * 1024;
const STATIC_RAM_BUDGET: u64 = 32 * 1024;

#[test]
#[ignore = "builds the board firmware: scripts/test-all.sh runs it with --ignored"]
fn f407_firmware_elf_has_its_parts_and_fits_the_budget() {
    // The build a user types, and the one that runs the designed controller's table.
    for (alias, profile) in [("fw-f407", "release"), ("fw-f407-designed", "release")] {
        let path = build_firmware(alias, profile, "tactile-f407");
        check_elf(&path, alias);
    }
}

fn check_elf(path: &std::path::Path, alias: &str) {
    let data = std::fs::read(path).expect("ELF readable");
    let elf = object::File::parse(&*data).expect("an ELF");
    assert_eq!(elf.architecture(), object::Architecture::Arm);

    let vectors = elf
        .section_by_name(".vector_table")
        .expect(".vector_table section");
    assert_eq!(
        vectors.address(),
        FLASH.start,
        "vector table not at 0x08000000"
    );
    let words: Vec<u32> = vectors
        .data()
        .expect("vector table data")
        .chunks_exact(4)
        .map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]))
        .collect();
    assert!(
        RAM.contains(&u64::from(words[0]).saturating_sub(1)),
        "initial SP {:#x}",
        words[0]
    );
    assert!(
        FLASH.contains(&u64::from(words[1])),
        "reset vector {:#x}",
        words[1]
    );
    assert_eq!(words[1] & 1, 1, "reset vector must be a Thumb address");

    let rtt = elf
        .symbols()
        .find(|s| s.name() == Ok("_SEGGER_RTT"))
        .expect("_SEGGER_RTT symbol (the RTT control block)");
    assert!(
        RAM.contains(&rtt.address()),
        "_SEGGER_RTT at {:#x}",
        rtt.address()
    );
    let defmt = elf.section_by_name(".defmt").expect(".defmt section");
    assert!(defmt.size() > 0, "empty .defmt section");
    // The board answers commands: the replies' formats are in its defmt table (each format
    // string is the name of a symbol in `.defmt`).
    for reply in ["CommandAck", "CommandRefused"] {
        assert!(
            elf.symbols()
                .any(|s| s.name().is_ok_and(|n| n.contains(reply))),
            "{alias}: no `{reply}` in the defmt table: the board does not answer commands"
        );
    }

    // Flash: everything loaded there (code, constants, and .data's initial values).
    // Static RAM: .data, .bss and .uninit (the stack takes the rest). CCM RAM: `.ccmram`,
    // never loaded (no bytes in the image: NOLOAD).
    let (mut flash, mut ram, mut ccm) = (0u64, 0u64, 0u64);
    for s in elf.sections() {
        let name = s.name().unwrap_or("");
        if FLASH.contains(&s.address()) {
            flash += s.size();
        }
        if RAM.contains(&s.address()) {
            ram += s.size();
            if name == ".data" {
                flash += s.size();
            }
        }
        if CCM.contains(&s.address()) && s.size() > 0 {
            assert_eq!(
                s.kind(),
                object::SectionKind::UninitializedData,
                "{alias}: {name} in CCM RAM has bytes to load; CCM is NOLOAD"
            );
            ccm += s.size();
        }
    }
    let label = format!("tactile-f407 (cargo {alias})");
    let flash_budget = if alias.ends_with("designed") {
        DESIGNED_FLASH_BUDGET
    } else {
        FLASH_BUDGET
    };
    println!(
        "{label}: flash {flash} B ({:.1} KiB of {} KiB), static RAM {ram} B ({:.1} KiB of {} KiB), CCM RAM {ccm} B of 64 KiB",
        flash as f64 / 1024.0,
        flash_budget / 1024,
        ram as f64 / 1024.0,
        STATIC_RAM_BUDGET / 1024
    );
    // The command port with room for a loaded calibration table (8 taxels) is in CCM RAM.
    let port = elf
        .symbols()
        .find(|s| s.name().is_ok_and(|n| n.contains("ccm4PORT")))
        .expect("the command port's CCM slot (ccm::PORT)");
    assert!(
        CCM.contains(&port.address()),
        "ccm::PORT at {:#x}",
        port.address()
    );
    assert!(
        port.size() > tactile_firmware::LOADED_TABLE_BYTES as u64,
        "ccm::PORT is {} B: no room for a loaded calibration table",
        port.size()
    );
    assert!(
        ccm <= CCM.end - CCM.start,
        "{label}: CCM RAM {ccm} B over 64 KiB"
    );
    assert!(
        flash <= flash_budget,
        "{label}: flash {flash} B over budget"
    );
    assert!(
        ram <= STATIC_RAM_BUDGET,
        "{label}: static RAM {ram} B over budget"
    );
}
