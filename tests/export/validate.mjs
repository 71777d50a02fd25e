// The Khronos glTF validator (npm `gltf-validator`) on grm's .glb files:
//   node tests/export/validate.mjs MODEL.glb...
// Prints each file's counts and exits 1 when any has an error (warnings
// and infos are printed, not fatal).
import { readFile } from "node:fs/promises";
import validator from "gltf-validator";

let failed = false;
for (const path of process.argv.slice(2)) {
  const bytes = new Uint8Array(await readFile(path));
  const report = await validator.validateBytes(bytes, { maxIssues: 50 });
  const { numErrors, numWarnings, numInfos, messages } = report.issues;
  console.log(
    `validate: ${path}: ${numErrors} errors, ${numWarnings} warnings, ${numInfos} infos` +
      ` (${report.validatorVersion})`,
  );
  for (const m of messages.filter((m) => m.severity <= 1)) {
    console.log(`  ${m.severity === 0 ? "error" : "warning"} ${m.code} at ${m.pointer ?? ""}: ${m.message}`);
  }
  if (numErrors > 0) failed = true;
}
process.exit(failed ? 1 : 0);
