"""Compile and sample Scenic programs emitted by Revelio, many in one process.

Reads one JSON job per stdin line: {"name": ..., "path": ..., "map": ..., "carla_map": ...}.
For each, compiles the program in 2D mode with the map parameters, and calls
`scenario.generate()` with Scenic's default iteration limit. Writes one JSON line per job to
stdout: {"name": ..., "ok": bool, "error": str|null, "iterations": int|null, "seconds": float}.
Maps are parsed once per file (Scenic caches the road network per process).
"""
import json
import sys
import time
import traceback
import warnings


def main():
    warnings.simplefilter("ignore")
    import scenic  # imported here so an import failure is reported once, clearly

    out = sys.stdout
    for line in sys.stdin:
        line = line.strip()
        if not line:
            continue
        job = json.loads(line)
        start = time.monotonic()
        result = {"name": job["name"], "ok": False, "error": None, "iterations": None}
        try:
            scenario = scenic.scenarioFromFile(
                job["path"], params={"map": job["map"], "carla_map": job["carla_map"]}, mode2D=True
            )
            scene, iterations = scenario.generate(verbosity=0)
            result["ok"] = True
            result["iterations"] = iterations
            result["objects"] = len(scene.objects)
        except BaseException as e:  # Scenic raises many types; report all, keep going
            if isinstance(e, KeyboardInterrupt):
                raise
            last = traceback.format_exception_only(type(e), e)[-1].strip()
            result["error"] = last
        result["seconds"] = round(time.monotonic() - start, 3)
        out.write(json.dumps(result) + "\n")
        out.flush()


if __name__ == "__main__":
    main()
