"""The .fmu archive and its binary: self-contained (no SUNDIALS, no libpkm) and exporting only
the FMI 2.0 and FMI 3.0 functions (one binary serves the FMI 2.0 and the FMI 3.0 FMU)."""
import re
import subprocess
import zipfile
from pathlib import Path

import fmpy

FMI2_FUNCTIONS = """fmi2GetTypesPlatform fmi2GetVersion fmi2SetDebugLogging fmi2Instantiate fmi2FreeInstance
fmi2SetupExperiment fmi2EnterInitializationMode fmi2ExitInitializationMode fmi2Terminate fmi2Reset
fmi2GetReal fmi2GetInteger fmi2GetBoolean fmi2GetString fmi2SetReal fmi2SetInteger fmi2SetBoolean
fmi2SetString fmi2GetFMUstate fmi2SetFMUstate fmi2FreeFMUstate fmi2SerializedFMUstateSize
fmi2SerializeFMUstate fmi2DeSerializeFMUstate fmi2GetDirectionalDerivative fmi2EnterEventMode
fmi2NewDiscreteStates fmi2EnterContinuousTimeMode fmi2CompletedIntegratorStep fmi2SetTime
fmi2SetContinuousStates fmi2GetDerivatives fmi2GetEventIndicators fmi2GetContinuousStates
fmi2GetNominalsOfContinuousStates fmi2SetRealInputDerivatives fmi2GetRealOutputDerivatives fmi2DoStep
fmi2CancelStep fmi2GetStatus fmi2GetRealStatus fmi2GetIntegerStatus fmi2GetBooleanStatus
fmi2GetStringStatus""".split()

# Every function of the FMI 3.0 standard: the function types its header declares.
FMI3_FUNCTIONS = sorted(set(re.findall(r"\b(fmi3\w+)TYPE\b", (Path(fmpy.__file__).parent / "c-code" /
                                                               "fmi3FunctionTypes.h").read_text())))
EXPORTED = set(FMI2_FUNCTIONS) | set(FMI3_FUNCTIONS)


def _binary(fmu_file, tmp_path):
    with zipfile.ZipFile(fmu_file) as z:
        z.extract("binaries/linux64/PKM_6PUS.so", tmp_path)
    return tmp_path / "binaries/linux64/PKM_6PUS.so"


def test_archive_layout(fmu_file):
    with zipfile.ZipFile(fmu_file) as z:
        names = set(z.namelist())
    assert "modelDescription.xml" in names
    assert "binaries/linux64/PKM_6PUS.so" in names
    assert not any("\\" in n for n in names)


def test_binary_needs_neither_sundials_nor_libpkm(fmu_file, tmp_path):
    so = _binary(fmu_file, tmp_path)
    dyn = subprocess.run(["readelf", "-d", str(so)], capture_output=True, text=True, check=True).stdout
    needed = re.findall(r"\(NEEDED\)\s+Shared library: \[([^\]]+)\]", dyn)
    assert needed, dyn
    assert not [n for n in needed if "sundials" in n or "pkm" in n], needed
    # Only the C runtime: the C++ runtime is linked in too, so a bare machine can load it.
    assert set(needed) <= {"libc.so.6", "libm.so.6", "ld-linux-x86-64.so.2"}, needed
    ldd = subprocess.run(["ldd", str(so)], capture_output=True, text=True).stdout
    assert "not found" not in ldd, ldd


def test_only_fmi_functions_are_exported(fmu_file, tmp_path):
    so = _binary(fmu_file, tmp_path)
    out = subprocess.run(["nm", "-D", "--defined-only", str(so)], capture_output=True, text=True, check=True).stdout
    exported = {line.split()[-1] for line in out.splitlines() if line.strip()}
    assert exported == EXPORTED, sorted(exported ^ EXPORTED)
    assert len(FMI3_FUNCTIONS) == 75  # the standard's 3.0 function set


def _platform_binary(fmu_file, tmp_path, platform, ext):
    name = f"binaries/{platform}/PKM_6PUS.{ext}"
    with zipfile.ZipFile(fmu_file) as z:
        assert name in z.namelist(), z.namelist()
        z.extract(name, tmp_path)
    return tmp_path / name


# What a Windows installation always has: the DLL carries libstdc++, libgcc and winpthread.
WINDOWS_SYSTEM_DLLS = {"kernel32.dll", "msvcrt.dll", "user32.dll", "advapi32.dll", "ws2_32.dll"}


def test_windows_binary_is_static_and_exports_only_the_fmi_functions(fmu_file, tmp_path):
    dll = _platform_binary(fmu_file, tmp_path, "win64", "dll")
    dump = subprocess.run(["x86_64-w64-mingw32-objdump", "-p", str(dll)], capture_output=True, text=True,
                          check=True).stdout
    assert "file format pei-x86-64" in subprocess.run(["x86_64-w64-mingw32-objdump", "-f", str(dll)],
                                                      capture_output=True, text=True, check=True).stdout
    imported = {n.lower() for n in re.findall(r"DLL Name: (\S+)", dump)}
    assert imported and imported <= WINDOWS_SYSTEM_DLLS, imported
    table = dump.split("[Ordinal/Name Pointer] Table")[1].split("\n\n")[0]
    exported = set(re.findall(r"\]\s+(\w+)", table))
    assert exported == EXPORTED, sorted(exported ^ EXPORTED)


def test_arm_binary_needs_only_the_c_runtime_and_exports_only_the_fmi_functions(fmu_file, tmp_path):
    so = _platform_binary(fmu_file, tmp_path, "aarch64-linux", "so")
    head = subprocess.run(["readelf", "-h", str(so)], capture_output=True, text=True, check=True).stdout
    assert "AArch64" in head
    dyn = subprocess.run(["readelf", "-d", str(so)], capture_output=True, text=True, check=True).stdout
    needed = set(re.findall(r"\(NEEDED\)\s+Shared library: \[([^\]]+)\]", dyn))
    assert needed and needed <= {"libc.so.6", "libm.so.6", "ld-linux-aarch64.so.1"}, needed
    syms = subprocess.run(["readelf", "--dyn-syms", "-W", str(so)], capture_output=True, text=True, check=True).stdout
    exported = {ln.split()[-1] for ln in syms.splitlines()
                if " GLOBAL " in ln and " DEFAULT " in ln and " UND " not in ln}
    assert exported == EXPORTED, sorted(exported ^ EXPORTED)
