"""Compile and sample Scenic programs emitted by Revelio, many in one process.

Reads one JSON job per stdin line: {"name": ..., "path": ..., "map": ..., "carla_map": ...}.
For each, compiles the program in 2D mode with the map parameters, and calls
`scenario.generate()` with Scenic's default iteration limit. Writes one JSON line per job to
stdout: {"name": ..., "ok": bool, "error": str|null, "iterations": int|null, "seconds": float}.
Maps are parsed once per file (Scenic caches the road network per process).
"""
import ast
import json
import sys
import time
import traceback
import warnings


def clone(node):
    """Deep copy of a (Scenic) AST. `copy.deepcopy` cannot rebuild Scenic's node classes, whose
    constructors require arguments, so copy instance dictionaries instead."""
    if isinstance(node, ast.AST):
        new = type(node).__new__(type(node))
        new.__dict__.update({k: clone(v) for k, v in node.__dict__.items()})
        return new
    if isinstance(node, list):
        return [clone(n) for n in node]
    return node


def main():
    warnings.simplefilter("ignore")
    import scenic  # imported here so an import failure is reported once, clearly
    from scenic.domains.driving import roads

    # Parsing an OpenDRIVE map takes seconds; every program of a run uses one of two maps.
    parse = roads.Network.fromFile
    networks = {}

    def cached(path, **options):
        key = (str(path), repr(sorted(options.items())))
        if key not in networks:
            networks[key] = parse(path, **options)
        return networks[key]

    roads.Network.fromFile = cached

    # Every program imports the CARLA world model, whose .scenic sources Scenic re-parses for
    # each scenario (about a second apiece); parse each source once and hand out copies, since
    # the compiler rewrites the tree it is given.
    from scenic.syntax import translator

    parse_string = translator.parse_string
    trees = {}

    def parse_cached(source, mode, *args, **kwargs):
        key = (source, mode, args, repr(sorted(kwargs.items())))
        if key not in trees:
            trees[key] = parse_string(source, mode, *args, **kwargs)
        return clone(trees[key])

    translator.parse_string = parse_cached

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
