// Run a Python program in the official MicroPython WebAssembly runtime, with files from this
// machine copied into its filesystem first (directories under /lib are on sys.path).
//
//   node run.mjs MANIFEST.json
//
// MANIFEST: {"heapsize": 65536, "files": {"/lib/roar_wire/spec.py": "/abs/path/spec.py", ...},
//            "main": "/abs/path/program.py"}
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
try {
  mp.runPython(program);
} catch (e) {
  process.stderr.write((e.message || String(e)) + "\n");
  process.exit(1);
}
