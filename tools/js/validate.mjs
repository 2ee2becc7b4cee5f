// Validate a glTF/GLB file with the Khronos glTF-Validator; print its report as JSON.
// Exit status 1 when it reports errors. Usage: node validate.mjs FILE
import fs from "node:fs";
import path from "node:path";
import validator from "gltf-validator";

const file = process.argv[2];
const data = new Uint8Array(fs.readFileSync(file));
const report = await validator.validateBytes(data, {
  uri: path.basename(file),
  maxIssues: 200,
  externalResourceFunction: (uri) =>
    new Promise((resolve, reject) => {
      fs.readFile(path.join(path.dirname(file), decodeURIComponent(uri)), (err, buf) =>
        err ? reject(err.toString()) : resolve(new Uint8Array(buf)));
    }),
});
console.log(JSON.stringify(report));
process.exit(report.issues.numErrors > 0 ? 1 : 0);
