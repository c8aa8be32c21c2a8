"""The .fmu archive and its binary: self-contained (no SUNDIALS, no libpkm) and exporting only fmi2*."""
import re
import subprocess
import zipfile

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


def test_only_fmi2_symbols_are_exported(fmu_file, tmp_path):
    so = _binary(fmu_file, tmp_path)
    out = subprocess.run(["nm", "-D", "--defined-only", str(so)], capture_output=True, text=True, check=True).stdout
    exported = {line.split()[-1] for line in out.splitlines() if line.strip()}
    assert exported == set(FMI2_FUNCTIONS), sorted(exported ^ set(FMI2_FUNCTIONS))
