// Prints the tasks a Hydrobake Flamenco job compiles to, without a Manager:
//   node farm/flamenco/tools/preview.js bakes="Water:caustics,Car:snow" frames=1-24 chunk_size=8
// Settings not given take the job type's defaults or the example values below.
"use strict";
const env = require("./flamenco_env.js");

const jt = env.load(require("node:path").join(__dirname, "..", "hydrobake.js"));
const settings = {
    bakes: "Water:caustics,Glass Pane:rain",
    frames: "1-24",
    render_output_root: "{jobs}/hydrobake_renders",
    blendfile: "{jobs}/shot_010/shot_010.flamenco.blend",
};
for (const s of jt.JOB_TYPE.settings) {
    if (s.default !== undefined && settings[s.key] === undefined) settings[s.key] = s.default;
}
let name = "shot_010";
for (const arg of process.argv.slice(2)) {
    const i = arg.indexOf("=");
    if (i < 1) throw new Error(`argument '${arg}': expected KEY=VALUE`);
    if (arg.slice(0, i) === "name") name = arg.slice(i + 1);
    else settings[arg.slice(0, i)] = arg.slice(i + 1);
}
const job = jt.compile(settings, { name, created: new Date() });
console.log(env.describe(job));
