// The Khronos glTF validator on one file: prints a JSON summary (errors, warnings, infos, hints and the
// first error/warning messages). Usage: node gltf_validate.js FILE.glb  (with NODE_PATH at the folder that
// holds node_modules/gltf-validator; `make gltf-validator` installs it into .cache/node).
const fs = require('fs');
const path = require('path');
const validator = require('gltf-validator');
const file = process.argv[2];
validator.validateBytes(new Uint8Array(fs.readFileSync(file)), {
  uri: file,
  externalResourceFunction: (uri) => new Promise((resolve, reject) => {
    fs.readFile(path.resolve(path.dirname(file), decodeURIComponent(uri)),
                (err, data) => err ? reject(err) : resolve(new Uint8Array(data)));
  })
}).then((r) => {
  const i = r.issues;
  console.log(JSON.stringify({errors: i.numErrors, warnings: i.numWarnings, infos: i.numInfos, hints: i.numHints,
    messages: i.messages.filter(m => m.severity <= 1).slice(0, 8)
      .map(m => `${m.severity} ${m.code} ${m.pointer || ''} ${m.message}`)}));
}).catch((e) => { console.log(JSON.stringify({fatal: String(e)})); process.exit(1); });
