"""Run OpenSim's own InverseDynamicsTool (the optional ``opensim`` package) on a trial.

    python tests/opensim_id_reference.py MODEL.osim IK.mot EXTERNAL_LOADS.xml T0 T1 OUT.sto

Writes OpenSim's generalized forces to ``OUT.sto`` (coordinates low-passed at 6 Hz,
muscles excluded, as in OpenSim's gait2354 example setup). Used by ``tests/test_gait.py``
as an independent cross-check and to make ``tests/data/gait2354_subject01_id_opensim46.sto``.

Run it in its own process: the ``opensim`` 4.6 wheel ships its own CasADi library, and
importing it next to the ``casadi`` package breaks one of them (undefined symbol).
"""
import os
import shutil
import sys
import tempfile


def main(model, motion, loads, t0, t1, out) -> None:
    import opensim
    opensim.Logger.removeFileSink()

    out = os.path.abspath(out)
    with tempfile.TemporaryDirectory() as work:
        # ExternalLoads name their data file relative to themselves: run beside copies
        for f in (model, motion, loads):
            shutil.copy(f, work)
        grf = open(loads).read().split("<datafile>")[1].split("</datafile>")[0].strip()
        shutil.copy(os.path.join(os.path.dirname(os.path.abspath(loads)), grf), work)
        os.chdir(work)
        tool = opensim.InverseDynamicsTool()
        osim_model = opensim.Model(os.path.basename(model))   # keep a reference: the tool does not own it
        tool.setModel(osim_model)
        tool.setCoordinatesFileName(os.path.basename(motion))
        tool.setExternalLoadsFileName(os.path.basename(loads))
        tool.setLowpassCutoffFrequency(6.0)
        tool.setStartTime(float(t0))
        tool.setEndTime(float(t1))
        excluded = opensim.ArrayStr()
        excluded.append("Muscles")
        tool.setExcludedForces(excluded)
        tool.setResultsDir(work)
        tool.setOutputGenForceFileName("id.sto")
        if not tool.run():
            raise SystemExit("OpenSim's InverseDynamicsTool failed")
        shutil.copy(os.path.join(work, "id.sto"), out)
    print(f"OpenSim {opensim.__version__}: {out}")


if __name__ == "__main__":
    if len(sys.argv) != 7:
        raise SystemExit(__doc__)
    main(*sys.argv[1:])
