// Run a Python program in the official MicroPython WebAssembly runtime, with files from this
// machine copied into its filesystem first (directories under /lib are on sys.path).
//
//   node run.mjs MANIFEST.json
//
// MANIFEST: {"heapsize": 65536, "files": {"/lib/roar_wire/spec.py": "/abs/path/spec.py", ...},
//            "main": "/abs/path/program.py"}
//
// A program that defines `roar_steps` (a generator) is then run step by step, each step in its
// own runPython call: this runtime collects garbage only between calls, so a long program must
// yield now and then or its heap only grows. Between steps the runner collects and measures the
// heap in use: at the end it calls `roar_finish(first, peak)` if defined, with the heap in use
// before the first step and the most in use before any step [bytes].
//
// The program's stdout and stderr pass through. Exit status: 0 when the program ran to its end,
// 1 when it raised (the traceback on stderr), 2 for a bad manifest. The runtime's own CLI exits
// 0 on a Python exception, which is why the suite runs its programs through this file.
import { readFileSync } from "node:fs";
import { dirname } from "node:path";
import { loadMicroPython } from "@micropython/micropython-webassembly-pyscript";

function fail(message) {
  process.stderr.write(`run.mjs: ${message}\n`);
  process.exit(2);
}

const manifestPath = process.argv[2];
if (!manifestPath) fail("usage: node run.mjs MANIFEST.json");
let manifest;
try {
  manifest = JSON.parse(readFileSync(manifestPath, "utf8"));
} catch (e) {
  fail(`cannot read ${manifestPath}: ${e.message}`);
}

const mp = await loadMicroPython({
  heapsize: manifest.heapsize || 64 * 1024,
  stdout: (line) => process.stdout.write(line + "\n"),
  stderr: (line) => process.stderr.write(line + "\n"),
});

function makeDirs(path) {
  let sofar = "";
  for (const part of path.split("/").filter(Boolean)) {
    sofar += "/" + part;
    try {
      mp.FS.mkdir(sofar);
    } catch (e) {
      // exists already
    }
  }
}

makeDirs("/lib");
for (const [target, source] of Object.entries(manifest.files || {})) {
  makeDirs(dirname(target));
  let data;
  try {
    data = readFileSync(source);
  } catch (e) {
    fail(`cannot read ${source}: ${e.message}`);
  }
  mp.FS.writeFile(target, data);
}

let program;
try {
  program = readFileSync(manifest.main, "utf8");
} catch (e) {
  fail(`cannot read the program ${manifest.main}: ${e.message}`);
}
const STEPPER = `
import gc
_roar_peak = 0
_roar_first = None
def _roar_sample():
    global _roar_peak, _roar_first
    gc.collect()
    used = gc.mem_alloc()
    _roar_first = used if _roar_first is None else _roar_first
    _roar_peak = max(_roar_peak, used)
def _roar_next():
    try:
        next(roar_steps)
        return True
    except StopIteration:
        return False
`;
try {
  mp.runPython(program);
  if (mp.globals.get("roar_steps") !== undefined) {
    mp.runPython(STEPPER);
    do {
      mp.runPython("_roar_sample()");
      mp.runPython("_roar_more = _roar_next()");
    } while (mp.globals.get("_roar_more"));
    if (mp.globals.get("roar_finish") !== undefined) mp.runPython("roar_finish(_roar_first, _roar_peak)");
  }
} catch (e) {
  process.stderr.write((e.message || String(e)) + "\n");
  process.exit(1);
}
