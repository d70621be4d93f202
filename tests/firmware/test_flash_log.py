"""The IARRC car keeps its signing key in flash erased a sector at a time (roar/flash_log.h): the
core's FlashLog on two sectors of memory that behave as flash does (bits only cleared, a word
never programmed twice, erased whole), through the simulated board's boots, key lines and power
cuts at every word of a write."""

import pytest

from roar.protocol import spec
from roar_sim.core.iarrc import IarrcBoard, IarrcTask
from roar_sim.core.library import ffi, lib
from roar_wire import signing

KEY = bytes(range(0x40, 0x50))
OTHER = bytes(range(0x60, 0x70))
SLOT_BYTES = 64  # [bytes] FlashLog::kSlotBytes
SPARE_SLOTS = 16  # FlashLog::kSpareSlots
SECTOR_BYTES = lib().ROAR_FLASH_SECTOR_BYTES  # [bytes]
SLOTS = SECTOR_BYTES // SLOT_BYTES


def boot(flash: bytes | None, power_words: int = -1) -> IarrcBoard:
    """A board on the flash a previous one left, its power cut after power_words words."""
    board = IarrcBoard(nvm=flash)
    board.hal.flash.power_words = power_words
    board.begin()
    return board


def host_line(board: IarrcBoard, text: str) -> list[str]:
    """A line on the host port, read by the host task: the lines the board answered."""
    board.host_out.clear()
    board.host(text.encode())
    board.run(IarrcTask.HOST, board.now_us)
    return [line for line in board.host_out.decode().splitlines() if not line.startswith("T ")]


def used_slots(flash: bytes) -> list[int]:
    """Slots that are not blank, in each sector."""
    return [sum(flash[o:o + SLOT_BYTES] != b"\xff" * SLOT_BYTES for o in range(s, s + SECTOR_BYTES, SLOT_BYTES))
            for s in (0, SECTOR_BYTES)]


def keyed_flash() -> bytes:
    board = boot(None)
    assert host_line(board, f"KEY {KEY.hex()}\n") == [f"KEY {signing.fingerprint(KEY)}", "SESSION 00000001"]
    return board.nvm


def test_every_boot_draws_a_new_session_and_the_sectors_take_turns_without_losing_the_key():
    flash, sessions, erases = keyed_flash(), [1], 0
    for _ in range(5 * SLOTS):
        board = boot(flash)
        assert board.hal.flash.double_programs == 0
        erases += board.hal.flash.erases
        sessions.append(board.session)
        flash = board.nvm
        assert min(SLOTS - n for n in used_slots(flash)) < SLOTS  # the key is always somewhere
    assert sessions == list(range(1, 5 * SLOTS + 2))  # never the same twice, never skipped back
    assert 5 * SLOTS // (SLOTS - SPARE_SLOTS) - 1 <= erases <= 5 * SLOTS // (SLOTS - SPARE_SLOTS) + 1
    assert host_line(boot(flash), "KEY ?\n") == [f"KEY {signing.fingerprint(KEY)}"]


@pytest.mark.parametrize("boots", [0, SLOTS - SPARE_SLOTS - 2, SLOTS - SPARE_SLOTS - 1, 2 * (SLOTS - SPARE_SLOTS) - 1])
def test_a_power_cut_at_any_word_of_a_boot_keeps_the_key_and_never_reuses_a_session(boots):
    """Cut the power after each number of words of a boot's writes (its session's copy, or the
    move to the other sector with its erase and then the session's copy): the board after it
    still has the key and a session above every session a board ran with."""
    flash = keyed_flash()
    for _ in range(boots):
        flash = boot(flash).nvm
    last = boot(flash)  # it ran with its session: no board after it may take that again
    moved = False
    for words in range(0, 2 * SLOT_BYTES // 4 + 1):
        cut = boot(last.nvm, power_words=words)
        moved |= cut.hal.flash.erases > 0
        ran = cut.session if cut.hal.flash.power_words != 0 else 0  # it ran only if the power held
        after = boot(cut.nvm)
        assert after.hal.flash.double_programs == cut.hal.flash.double_programs == 0
        assert host_line(after, "KEY ?\n") == [f"KEY {signing.fingerprint(KEY)}"], words
        assert after.session > max(last.session, ran), words
    assert moved == (boots % (SLOTS - SPARE_SLOTS) == SLOTS - SPARE_SLOTS - 1)  # the case meant


def test_a_key_change_on_a_full_sector_is_refused_until_the_next_boot_makes_room():
    board = boot(keyed_flash())
    changes = 0
    while (answer := host_line(board, f"KEY {OTHER.hex()}\n"))[0].startswith("KEY"):
        changes += 1
        assert board.session == changes + 2  # each change is a new session
    assert answer == ["ERR nokey"] and changes >= SPARE_SLOTS - 1
    assert host_line(board, "KEY ?\n") == [f"KEY {signing.fingerprint(OTHER)}"]  # refused: nothing changed
    again = boot(board.nvm)  # moves to the other sector
    assert host_line(again, "KEY -\n") == ["KEY none"]
    assert host_line(boot(again.nvm), "KEY ?\n") == ["KEY none"]


def test_the_flash_abi_is_the_one_the_library_was_built_with():
    assert ffi.sizeof("roar_flash_t") == 16 + 2 * SECTOR_BYTES
    assert spec.SIGNED_KEY_BYTES == 16
