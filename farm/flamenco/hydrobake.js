// Hydrobake job type for Flamenco 3.x (job type name "hydrobake", from this file's name).
//
// Bakes every object/effect of a .blend as its own task (a simulation runs through its frames
// in order, so one bake is one task; different objects are independent and run in parallel),
// wires them into a copy of the .blend, and renders frame chunks of that copy. The bakes and
// the copy live in a per-job folder on shared storage; the submitted .blend is only read.
// Install: copy this file into the `scripts/` folder next to `flamenco-manager` (README.md).

const JOB_TYPE = {
    label: "Hydrobake Bake & Render",
    description: "Bake each Hydrobake object/effect as its own task, then render frame chunks",
    settings: [
        // Filled in by Blender's Flamenco add-on, evaluated in the artist's Blender.
        { key: "bakes", type: "string", required: true,
          eval: "','.join(f'{o.name}:{k[10:]}' for o in bpy.data.objects"
              + " for k in o.bl_rna.properties.keys()"
              + " if k.startswith('hydrobake_') and getattr(o, k).enabled)",
          evalInfo: { showLinkButton: true, description: "Every object with an enabled Hydrobake effect" },
          description: "Bakes to run as OBJECT:EFFECT pairs separated by commas, e.g. "
              + "'Water:caustics,Glass Pane:rain'. Each pair is one task" },
        { key: "frames", type: "string", required: true,
          eval: "f'{C.scene.frame_start}-{C.scene.frame_end}'",
          evalInfo: { showLinkButton: true, description: "Scene frame range" },
          description: "One frame range START-END: baked in order, then rendered in chunks" },
        { key: "chunk_size", type: "int32", default: 1, propargs: { min: 1 }, visible: "submission",
          description: "Number of frames to render in one render task" },
        { key: "threads", type: "int32", default: 0, propargs: { min: 0, max: 256 }, visible: "submission",
          description: "Threads per bake, 0 = all cores of the worker; the result does not depend on it" },
        { key: "resume_bakes", type: "bool", default: false, visible: "submission",
          description: "Bake tasks run 'resume' instead of 'bake': a task retried after a lost worker "
              + "continues from the last checkpoint (bit-identical) instead of starting over" },
        { key: "cache_root", type: "string", subtype: "dir_path", required: true,
          default: "{jobs}/hydrobake_cache", visible: "submission",
          description: "Shared folder for the bakes, seen by every worker (use a Flamenco variable "
              + "such as {jobs}); each job bakes into its own subfolder" },
        { key: "render_output_root", type: "string", subtype: "dir_path", required: true, visible: "submission",
          description: "Shared folder for the rendered frames; each job renders into its own subfolder" },

        // Set by the add-on (the packed .blend) and by compileJob (for the web interface).
        { key: "blendfile", type: "string", required: true, visible: "web",
          description: "The .blend to bake and render" },
        { key: "cache_path", type: "string", subtype: "dir_path", visible: "web",
          description: "Folder this job bakes into" },
        { key: "render_blendfile", type: "string", subtype: "file_path", visible: "web",
          description: "The .blend with the bakes wired in, which the render tasks render" },
        { key: "render_output_path", type: "string", subtype: "hashed_file_path", visible: "web",
          description: "Frames this job renders" },
    ],
};

// Our batch command line (blender_addon/hydrobake/blender/cli.py); runs after the .blend loads.
const CLI = "import hydrobake.blender.cli as c; c.main()";

// The CLI saves the .blend after a bake. Bake tasks run at the same time on one .blend, and
// concurrent saves of one file lose each other's wiring and can corrupt it (they share
// Blender's temporary "FILE.blend@"). So each bake task first moves to a private local copy
// with the same file name (bake folders are named after it): the submitted file is only read.
const CLI_ON_COPY = [
    "import bpy, os, shutil, tempfile",
    "d = tempfile.mkdtemp(prefix='hydrobake-')",
    "bpy.ops.wm.save_as_mainfile(filepath=os.path.join(d, os.path.basename(bpy.data.filepath)))",
    "import hydrobake.blender.cli as c",
    "try:",
    "    c.main()",
    "finally:",
    "    shutil.rmtree(d, ignore_errors=True)",
].join("\n");

// The wiring task works on its own copy of the .blend, saved in the job's cache folder under
// the same file name (bake folders are named after it): the submitted file stays untouched;
// with Flamenco's "work directly on shared storage" it is the artist's own file.
const SAVE_COPY = [
    "import bpy, os, sys",
    "os.makedirs(os.path.dirname(sys.argv[-1]), exist_ok=True)",
    "bpy.ops.wm.save_as_mainfile(filepath=sys.argv[-1])",
].join("\n");

// The wiring stores absolute paths as the worker saw them; relative ones ('//...') also resolve
// on workers of other platforms and mounts. Only paths under the cache folder (last argument)
// change: images, volumes, baked mesh sequences and bake folders (the addon's
// paths.make_relative).
const PATHS_RELATIVE = [
    "import bpy, sys",
    "from hydrobake.blender import paths",
    "paths.make_relative(sys.argv[-1])",
    "bpy.ops.wm.save_mainfile()",
].join("\n");

function compileJob(job) {
    const settings = job.settings;
    const frames = parseFrames(settings.frames);
    const bakes = parseBakes(settings.bakes);
    const chunkSize = intSetting(settings, "chunk_size", 1, 1);
    const threads = intSetting(settings, "threads", 0, 0);
    const blendfile = stringSetting(settings, "blendfile");

    // A folder per job: two jobs of the same shot must not bake into each other's files.
    const jobDir = `${safeName(job.name)}_${formatTimestampLocal(job.created)}`;
    const cache = path.join(stringSetting(settings, "cache_root"), jobDir);
    const renderOutput = path.join(stringSetting(settings, "render_output_root"), jobDir, "######");
    settings.cache_path = cache;
    settings.render_output_path = renderOutput;
    print("hydrobake:", bakes.length, "bakes of frames", frames, "into", cache, "; frames to", renderOutput);

    // Paths stay whole arguments that start with a variable, so that Flamenco's two-way
    // variables translate them for each worker's platform.
    const shared = ["--frames", frames, "--output", cache, "--threads", String(threads)];
    const verb = settings.resume_bakes === true ? "resume" : "bake";

    // A task must be complete (commands and dependencies) before job.addTask(): the Manager
    // stores a copy of the task at that moment.
    const bakeTasks = bakes.map((b) => {
        const task = author.Task(`bake ${b.object}/${b.effect}`, "blender");
        task.addCommand(blender(blendfile, CLI_ON_COPY,
            [verb, "--objects", b.object, "--effects", b.effect].concat(shared)));
        job.addTask(task);
        return task;
    });

    // Wire every finished bake into the render copy, one after another in one task: 'resume'
    // of a complete bake bakes nothing (it re-bakes a frame whose checksum fails), then wires it
    // and saves the file.
    const renderBlend = path.join(cache, path.basename(blendfile));
    settings.render_blendfile = renderBlend;
    const wire = author.Task("wire bakes", "blender");
    wire.addCommand(blender(blendfile, SAVE_COPY, [renderBlend]));
    for (const b of bakes) {
        wire.addCommand(blender(renderBlend, CLI,
            ["resume", "--objects", b.object, "--effects", b.effect].concat(shared)));
    }
    wire.addCommand(blender(renderBlend, PATHS_RELATIVE, [cache]));
    for (const t of bakeTasks) wire.addDependency(t);
    job.addTask(wire);

    // Every frame shows every effect: each render task waits for all bakes and the wiring.
    for (const chunk of frameChunker(frames, chunkSize)) {
        const task = author.Task(`render-${chunk}`, "blender");
        task.addCommand(author.Command("blender-render", {
            exe: "{blender}",
            exeArgs: "{blenderArgs}",
            argsBefore: [],
            blendfile: renderBlend,
            args: ["--render-output", renderOutput,
                   "--render-frame", chunk.replaceAll("-", "..")],  // Blender's range notation
        }));
        for (const t of bakeTasks) task.addDependency(t);
        task.addDependency(wire);
        job.addTask(task);
    }
}

// Blender in background mode ({blenderArgs}, '-b -y' by default) running a Python expression;
// --python-exit-code makes a Python error fail the task. Arguments after '--' are the script's.
function blender(blendfile, expr, scriptArgs) {
    return author.Command("blender-render", {
        exe: "{blender}",
        exeArgs: "{blenderArgs}",
        argsBefore: [],
        blendfile: blendfile,
        args: ["--python-exit-code", "1", "--python-expr", expr, "--"].concat(scriptArgs),
    });
}

function fail(message) {
    throw new Error("hydrobake: " + message);
}

// "S-E", "S..E" or "S" -> "S-E". One contiguous range: a bake simulates every frame in order.
function parseFrames(value) {
    const text = value === undefined || value === null ? "" : String(value);
    const m = /^\s*(\d+)\s*(?:(?:-|\.\.)\s*(\d+)\s*)?$/.exec(text);
    if (!m) fail(`frames '${text}': must be one range START-END, e.g. '1-48'`);
    const start = Number(m[1]);
    const end = m[2] === undefined ? start : Number(m[2]);
    if (end < start) fail(`frames '${text}': END must not be before START`);
    return `${start}-${end}`;
}

// "Water:caustics, Glass Pane:rain" -> [{object, effect}]. The last ':' separates, so object
// names may contain ':'; they cannot contain ',' (nor can the CLI's --objects list).
function parseBakes(value) {
    const entries = String(value || "").split(",").map((e) => e.trim()).filter((e) => e !== "");
    if (entries.length === 0) {
        fail("no bakes: set 'bakes' to OBJECT:EFFECT pairs, e.g. 'Water:caustics' "
            + "(enable a Hydrobake effect on an object, or see the 'list' command)");
    }
    const seen = new Set();
    return entries.map((entry) => {
        const i = entry.lastIndexOf(":");
        const object = entry.slice(0, Math.max(i, 0)).trim();
        const effect = entry.slice(i + 1).trim();
        if (i < 0 || object === "" || !/^[a-z][a-z0-9_]*$/.test(effect)) {
            fail(`bakes entry '${entry}': must be OBJECT:EFFECT, e.g. 'Water:caustics' `
                + "(object names cannot contain ',')");
        }
        if (seen.has(object + ":" + effect)) {
            fail(`bakes entry '${entry}' is listed twice (two tasks would write one bake folder)`);
        }
        seen.add(object + ":" + effect);
        return { object: object, effect: effect };
    });
}

function intSetting(settings, key, fallback, min) {
    const raw = settings[key];
    const value = raw === undefined || raw === null || raw === "" ? fallback : Number(raw);
    if (!Number.isInteger(value) || value < min) fail(`${key} = ${raw}: must be a whole number >= ${min}`);
    return value;
}

function stringSetting(settings, key) {
    const value = settings[key];
    if (typeof value !== "string" || value.trim() === "") fail(`${key}: required, got '${value}'`);
    return value;
}

// A job name as one safe path component.
function safeName(name) {
    return String(name || "").replace(/[^A-Za-z0-9._-]+/g, "_").slice(0, 64) || "job";
}
