"""benchmarks/run_all.py decides from /proc/cpuinfo whether the CPU has bfloat16 units (no torch needed)."""
import argparse
import pathlib
import sys

BENCH = pathlib.Path(__file__).resolve().parent.parent / "benchmarks"
if str(BENCH) not in sys.path:
    sys.path.insert(0, str(BENCH))

import run_all  # noqa: E402

ZEN3 = """processor\t: 0
vendor_id\t: AuthenticAMD
cpu family\t: 25
model\t\t: 1
model name\t: AMD EPYC 7B13
flags\t\t: fpu vme de pse tsc msr pae mce cx8 sse sse2 ht syscall avx f16c fma avx2 bmi2 sha_ni
bugs\t\t: sysret_ss_attrs spectre_v1 spectre_v2

processor\t: 1
flags\t\t: fpu vme de pse tsc msr pae mce cx8 sse sse2 ht syscall avx f16c fma avx2 bmi2 sha_ni
"""
SAPPHIRE_RAPIDS = ("processor\t: 0\nvendor_id\t: GenuineIntel\nflags\t\t: fpu avx2 avx512f avx512bw avx512_vnni "
                   "avx512_bf16 avx512_fp16 amx_bf16 amx_tile amx_int8\n")
ZEN4 = "processor\t: 0\nvendor_id\t: AuthenticAMD\nflags\t\t: fpu avx2 avx512f avx512_bf16 avx512_vnni\n"
GRAVITON3 = "processor\t: 0\nBogoMIPS\t: 2100.00\nFeatures\t: fp asimd evtstrm aes pmull sha1 sve bf16 i8mm\n"
GRAVITON2 = "processor\t: 0\nBogoMIPS\t: 243.75\nFeatures\t: fp asimd evtstrm aes pmull sha1 sha2 crc32 atomics\n"


def test_no_bfloat16_units_on_avx2_cpu():
    ok, reason = run_all.bf16_support(ZEN3)
    assert ok is False
    assert "amx_bf16" in reason and "avx512_bf16" in reason and "no bfloat16 units" in reason


def test_bfloat16_flags_found():
    ok, reason = run_all.bf16_support(SAPPHIRE_RAPIDS)
    assert ok is True and "amx_bf16" in reason and "avx512_bf16" in reason
    ok, reason = run_all.bf16_support(ZEN4)
    assert ok is True and "avx512_bf16" in reason and "amx_bf16" not in reason


def test_aarch64_features_line():
    assert run_all.bf16_support(GRAVITON3)[0] is True
    assert run_all.bf16_support(GRAVITON2)[0] is False


def test_flag_names_are_whole_words_and_empty_text_is_unknown():
    # "avx512_bf16x" is not the flag; a cpuinfo without flag lines cannot tell
    ok, _ = run_all.bf16_support("flags\t\t: fpu avx512_bf16x amx_bf16_like\n")
    assert ok is False
    ok, reason = run_all.bf16_support("")
    assert ok is False and "unknown" in reason


def test_command_line_overrides_the_detection():
    assert run_all.bf16_decision(argparse.Namespace(bf16="on")) == (True, "--bf16 on")
    assert run_all.bf16_decision(argparse.Namespace(bf16="off")) == (False, "--bf16 off")
