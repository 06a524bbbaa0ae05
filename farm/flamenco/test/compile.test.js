// Compiles Hydrobake Flamenco jobs in Node against stand-ins for Flamenco's documented
// job-compiler globals (../tools/flamenco_env.js). Run: node --test farm/flamenco/test/
"use strict";
const assert = require("node:assert/strict");
const { spawnSync } = require("node:child_process");
const path = require("node:path");
const test = require("node:test");
const env = require("../tools/flamenco_env.js");

const SCRIPT = path.join(__dirname, "..", "hydrobake.js");
const CREATED = new Date(2024, 4, 17, 9, 30, 5);
const STAMP = "2024-05-17_093005";

const BASE = {
    bakes: "Water:caustics, Glass Pane:rain,Car:snow",
    frames: "1-10",
    chunk_size: 3,
    threads: 2,
    resume_bakes: false,
    cache_root: "{jobs}/hydrobake_cache",
    render_output_root: "{renders}/shots",
    blendfile: "{jobs}/shot_010/shot_010.flamenco.blend",
};

function compile(overrides = {}, options = {}) {
    const jt = env.load(SCRIPT);
    return jt.compile({ ...BASE, ...overrides }, { name: "Shot 010 / final", created: CREATED, ...options });
}

const bakeTasks = (job) => job.tasks.filter((t) => t.name.startsWith("bake "));
const renderTasks = (job) => job.tasks.filter((t) => t.name.startsWith("render-"));
const wireTask = (job) => job.tasks.find((t) => t.name === "wire bakes");
const depIds = (task) => task.dependencies.map((d) => d.uuid).sort();
const uuids = (tasks) => tasks.map((t) => t.uuid).sort();

// The Hydrobake CLI arguments after Blender's '--'.
function cliArgs(command) {
    const args = command.parameters.args;
    return args.slice(args.indexOf("--") + 1);
}
function option(args, name) {
    const i = args.indexOf(name);
    assert.ok(i >= 0 && i + 1 < args.length, `${name} missing in ${args.join(" ")}`);
    return args[i + 1];
}
// "1..3" / "9,10" / "4" -> frame numbers.
function framesOf(blenderRange) {
    return blenderRange.split(",").flatMap((part) => {
        const [a, b = a] = part.split("..").map(Number);
        return Array.from({ length: b - a + 1 }, (_, i) => a + i);
    });
}

test("the stand-in frameChunker behaves as Flamenco documents it", () => {
    assert.deepEqual(env.frameChunker("1..10,20..25,40,3..8", 4), ["1-4", "5-8", "9,10,20,21", "22-25", "40"]);
    assert.deepEqual(env.frameChunker(" 1  .. 10,\t20..25\n,40   ", 4), ["1-4", "5-8", "9,10,20,21", "22-25", "40"]);
    assert.deepEqual(env.frameChunker("47", 4), ["47"]);
    assert.deepEqual(env.frameChunker("1-3", 3), ["1-3"]);
    assert.throws(() => env.frameChunker("   ", 4), /empty range/);
    assert.throws(() => env.frameChunker(" 1 10", 4), /1 10/);
    assert.equal(env.path.join("{jobs}/cache", "shot_1", "######"), "{jobs}/cache/shot_1/######");
    assert.equal(env.path.join("{jobs}/cache/", "a"), "{jobs}/cache/a");
    assert.equal(env.path.stem("{jobs}/x/shot.flamenco.blend"), "shot.flamenco");
    assert.equal(env.formatTimestampLocal(CREATED), STAMP);
});

test("JOB_TYPE follows the documented AvailableJobType/AvailableJobSetting schema", () => {
    const { JOB_TYPE } = env.load(SCRIPT);
    assert.equal(typeof JOB_TYPE.label, "string");
    assert.ok(JOB_TYPE.label.length > 0);
    assert.ok(Array.isArray(JOB_TYPE.settings));
    // The Manager exports JOB_TYPE to JSON for the add-on and the web interface.
    // (structuredClone brings it out of the script's realm and refuses functions.)
    assert.deepEqual(JSON.parse(JSON.stringify(JOB_TYPE)), structuredClone(JOB_TYPE));

    const fields = new Set(["key", "type", "subtype", "choices", "propargs", "description", "label",
        "default", "eval", "evalInfo", "visible", "required", "editable"]);
    const types = { string: "string", int32: "number", float: "number", bool: "boolean" };
    const seen = new Set();
    for (const s of JOB_TYPE.settings) {
        for (const k of Object.keys(s)) assert.ok(fields.has(k), `${s.key}: unknown field ${k}`);
        // Keys become Blender property names in the add-on.
        assert.match(s.key, /^[a-z][a-z0-9_]*$/);
        assert.ok(!seen.has(s.key), `${s.key} defined twice`);
        seen.add(s.key);
        assert.ok(s.type in types, `${s.key}: type ${s.type}`);
        if ("subtype" in s) {
            assert.equal(s.type, "string", `${s.key}: subtype only for strings`);
            assert.ok(["file_path", "dir_path", "file_name", "hashed_file_path"].includes(s.subtype));
        }
        if ("choices" in s) assert.ok(s.type === "string" && s.choices.every((c) => typeof c === "string"));
        if ("default" in s) {
            assert.equal(typeof s.default, types[s.type], `${s.key}: default type`);
            if (s.type === "int32") assert.ok(Number.isInteger(s.default));
        }
        if ("visible" in s) assert.ok(["visible", "hidden", "submission", "web"].includes(s.visible));
        for (const k of ["required", "editable"]) if (k in s) assert.equal(typeof s[k], "boolean");
        for (const k of ["description", "label", "eval"]) if (k in s) assert.equal(typeof s[k], "string");
        if ("propargs" in s) assert.equal(typeof s.propargs, "object");
        if ("evalInfo" in s) {
            assert.ok("eval" in s, `${s.key}: evalInfo without eval`);
            assert.equal(typeof s.evalInfo.showLinkButton, "boolean");
            assert.equal(typeof s.evalInfo.description, "string");
        }
    }
    for (const key of ["bakes", "frames", "chunk_size", "threads", "resume_bakes", "cache_root",
        "render_output_root", "blendfile", "cache_path", "render_output_path", "render_blendfile"]) {
        assert.ok(seen.has(key), `setting ${key} missing`);
    }
    const byKey = Object.fromEntries(JOB_TYPE.settings.map((s) => [s.key, s]));
    // The add-on sets the packed .blend's path only into a string setting named "blendfile".
    assert.equal(byKey.blendfile.type, "string");
    assert.ok(byKey.cache_root.default.startsWith("{jobs}/"));
    for (const key of ["bakes", "frames", "cache_root", "render_output_root", "blendfile"]) {
        assert.equal(byKey[key].required, true, `${key} must be required`);
    }
    // The add-on makes a non-editable setting read-only through a getter returning its eval or
    // default value; without either, that getter would fail.
    for (const s of JOB_TYPE.settings.filter((s) => s.editable === false)) {
        assert.ok("eval" in s || "default" in s, `${s.key}: editable false needs eval or default`);
    }
});

test("the Python snippets are valid Python", (t) => {
    const probe = spawnSync("python3", ["--version"]);
    if (probe.error) return t.skip("python3 not found");
    const { JOB_TYPE } = env.load(SCRIPT);
    const job = compile();
    const snippets = new Set();
    for (const task of job.tasks) {
        for (const c of task.commands) {
            const a = c.parameters.args;
            if (a.includes("--python-expr")) snippets.add(a[a.indexOf("--python-expr") + 1]);
        }
    }
    assert.equal(snippets.size, 4); // bake on a copy, save the render copy, CLI, relative paths
    const check = (src, mode) => spawnSync("python3", ["-c",
        `import sys; compile(sys.stdin.read(), 'snippet', '${mode}')`], { input: src, encoding: "utf8" });
    for (const src of snippets) {
        const r = check(src, "exec");
        assert.equal(r.status, 0, `${src}\n${r.stderr}`);
    }
    for (const s of JOB_TYPE.settings.filter((s) => s.eval)) {
        const r = check(s.eval, "eval");
        assert.equal(r.status, 0, `${s.key}: ${r.stderr}`);
    }
});

test("one bake task per object/effect, running the Hydrobake CLI", () => {
    const job = compile();
    const bakes = bakeTasks(job);
    assert.deepEqual(bakes.map((t) => t.name), ["bake Water/caustics", "bake Glass Pane/rain", "bake Car/snow"]);
    const cache = `{jobs}/hydrobake_cache/Shot_010_final_${STAMP}`;
    const expected = [["Water", "caustics"], ["Glass Pane", "rain"], ["Car", "snow"]];
    bakes.forEach((task, i) => {
        assert.equal(task.type, "blender");
        assert.equal(task.commands.length, 1);
        const cmd = task.commands[0];
        assert.equal(cmd.name, "blender-render");
        const p = cmd.parameters;
        assert.equal(p.exe, "{blender}");
        assert.equal(p.exeArgs, "{blenderArgs}");
        assert.deepEqual(p.argsBefore, []);
        assert.equal(p.blendfile, BASE.blendfile);
        const a = p.args;
        assert.deepEqual(a.slice(0, 3), ["--python-exit-code", "1", "--python-expr"]);
        assert.match(a[3], /import hydrobake\.blender\.cli as c/);
        assert.match(a[3], /c\.main\(\)/);
        assert.match(a[3], /save_as_mainfile/); // bakes on a private copy of the .blend
        // A name with spaces stays one argument: Flamenco passes args as an argv list, no shell.
        assert.deepEqual(cliArgs(cmd), ["bake", "--objects", expected[i][0], "--effects", expected[i][1],
            "--frames", "1-10", "--output", cache, "--threads", "2"]);
        assert.ok(cliArgs(cmd).every((x) => !/["']/.test(x)), "no shell quoting in argv");
    });
});

test("bake tasks are independent; everything else waits for all of them", () => {
    const job = compile();
    const bakes = bakeTasks(job);
    for (const t of bakes) assert.deepEqual(t.dependencies, [], `${t.name} must not wait`);
    const wire = wireTask(job);
    assert.deepEqual(depIds(wire), uuids(bakes));
    const renders = renderTasks(job);
    assert.ok(renders.length > 0);
    for (const r of renders) {
        for (const b of bakes) assert.ok(depIds(r).includes(b.uuid), `${r.name} must wait for ${b.name}`);
        assert.ok(depIds(r).includes(wire.uuid), `${r.name} must wait for the wiring`);
    }
    // Nothing else, and every dependency is a task of this job.
    assert.equal(job.tasks.length, bakes.length + 1 + renders.length);
    const all = new Set(job.tasks.map((t) => t.uuid));
    for (const t of job.tasks) for (const d of t.dependencies) assert.ok(all.has(d.uuid));
});

test("the wiring task copies the .blend, resumes each finished bake into it, relativizes", () => {
    const job = compile();
    const wire = wireTask(job);
    assert.equal(wire.type, "blender");
    assert.equal(wire.commands.length, 5);
    const cache = `{jobs}/hydrobake_cache/Shot_010_final_${STAMP}`;
    const copy = `${cache}/shot_010.flamenco.blend`; // same file name: bake folders follow it
    assert.equal(job.settings.render_blendfile, copy);
    const [save, ...rest] = wire.commands;
    assert.equal(save.parameters.blendfile, BASE.blendfile);
    assert.match(save.parameters.args[3], /save_as_mainfile\(filepath=sys\.argv\[-1\]\)/);
    assert.deepEqual(cliArgs(save), [copy]);
    const pairs = [["Water", "caustics"], ["Glass Pane", "rain"], ["Car", "snow"]];
    pairs.forEach(([object, effect], i) => {
        const cmd = rest[i];
        assert.equal(cmd.parameters.blendfile, copy);
        assert.equal(cmd.parameters.args[3], "import hydrobake.blender.cli as c; c.main()");
        assert.deepEqual(cliArgs(cmd), ["resume", "--objects", object, "--effects", effect,
            "--frames", "1-10", "--output", cache, "--threads", "2"]);
    });
    const last = rest[3];
    assert.equal(last.parameters.blendfile, copy);
    assert.match(last.parameters.args[3], /paths\.make_relative\(sys\.argv\[-1\]\)/);
    assert.deepEqual(cliArgs(last), [cache]);
});

test("the submitted .blend is only read; renders use the wired copy", () => {
    const job = compile();
    const copy = job.settings.render_blendfile;
    for (const r of renderTasks(job)) assert.equal(r.commands[0].parameters.blendfile, copy);
    // Commands that open the submitted file either save elsewhere first (bakes, the copy) ...
    for (const t of job.tasks) {
        for (const c of t.commands.filter((c) => c.parameters.blendfile === BASE.blendfile)) {
            assert.match(c.parameters.args[3], /^import bpy, os/, `${t.name} opens the submitted file`);
            assert.match(c.parameters.args[3], /save_as_mainfile\(filepath=/);
        }
    }
    // ... and a bake task saves its copy somewhere private, never in the shared folders.
    for (const b of bakeTasks(job)) assert.match(b.commands[0].parameters.args[3], /tempfile\.mkdtemp/);
});

test("render chunks cover the frame range exactly once", () => {
    for (const [frames, chunk] of [["1-10", 3], ["1..48", 8], ["7", 4], ["0-4", 10], ["5-6", 1], ["3-12", 2]]) {
        const job = compile({ frames, chunk_size: chunk });
        const [start, end] = frames.split(/-|\.\./).map(Number).concat(Number(frames)).slice(0, 2);
        const want = Array.from({ length: (end || start) - start + 1 }, (_, i) => start + i);
        const got = [];
        for (const t of renderTasks(job)) {
            assert.equal(t.type, "blender");
            assert.equal(t.commands.length, 1);
            const p = t.commands[0].parameters;
            assert.equal(t.commands[0].name, "blender-render");
            assert.equal(p.exe, "{blender}");
            assert.equal(p.blendfile, job.settings.render_blendfile);
            const f = framesOf(option(p.args, "--render-frame"));
            assert.ok(f.length <= chunk, `${t.name}: ${f.length} frames > chunk ${chunk}`);
            got.push(...f);
        }
        assert.deepEqual(got, want, `frames ${frames} chunk ${chunk}`);
        // The bakes cover the same range.
        for (const b of bakeTasks(job)) {
            assert.equal(option(cliArgs(b.commands[0]), "--frames"), `${want[0]}-${want[want.length - 1]}`);
        }
    }
});

test("paths are whole arguments in Flamenco's variable form", () => {
    const job = compile();
    const cache = `{jobs}/hydrobake_cache/Shot_010_final_${STAMP}`;
    const output = `{renders}/shots/Shot_010_final_${STAMP}/######`;
    assert.equal(job.settings.cache_path, cache);
    assert.equal(job.settings.render_output_path, output);
    for (const t of job.tasks) {
        for (const c of t.commands) {
            const p = c.parameters;
            assert.equal(p.exe, "{blender}");
            assert.ok(p.blendfile.startsWith("{jobs}/"));
            const copy = job.settings.render_blendfile;
            for (const a of p.args) assert.equal(typeof a, "string", `${t.name}: non-string argument`);
            // Two-way variables translate a path prefix, so a path must start its argument.
            for (const a of p.args.filter((x) => x.includes("{jobs}") || x.includes("{renders}"))) {
                assert.ok([cache, output, copy].includes(a), `${t.name}: path inside an argument: ${a}`);
            }
        }
    }
    for (const r of renderTasks(job)) assert.equal(option(r.commands[0].parameters.args, "--render-output"), output);
    // A Windows-style root from a two-way variable keeps working.
    const win = compile({ cache_root: "{storage}\\hydrobake" });
    assert.equal(win.settings.cache_path, `{storage}/hydrobake/Shot_010_final_${STAMP}`);
});

test("options: resume bakes, threads, odd object names", () => {
    let job = compile({ resume_bakes: true, threads: 0 });
    for (const b of bakeTasks(job)) {
        assert.equal(cliArgs(b.commands[0])[0], "resume");
        assert.equal(option(cliArgs(b.commands[0]), "--threads"), "0");
    }
    job = compile({ bakes: "Sign: Exit:caustics" });
    assert.deepEqual(cliArgs(bakeTasks(job)[0].commands[0]).slice(0, 5),
        ["bake", "--objects", "Sign: Exit", "--effects", "caustics"]);
    // Defaults apply when an API submitter leaves settings out.
    job = compile({ chunk_size: undefined, threads: undefined });
    assert.equal(option(cliArgs(bakeTasks(job)[0].commands[0]), "--threads"), "0");
    assert.equal(renderTasks(job).length, 10);
    job = compile({}, { name: "" });
    assert.match(job.settings.cache_path, new RegExp(`/job_${STAMP}$`));
});

test("bad settings are refused with a clear message", () => {
    const bad = [
        [{ bakes: "" }, /no bakes/],
        [{ bakes: " , ," }, /no bakes/],
        [{ bakes: undefined }, /no bakes/],
        [{ bakes: "Water" }, /'Water': must be OBJECT:EFFECT/],
        [{ bakes: "Water:" }, /must be OBJECT:EFFECT/],
        [{ bakes: ":caustics" }, /must be OBJECT:EFFECT/],
        [{ bakes: "Water:Caustics!" }, /must be OBJECT:EFFECT/],
        [{ bakes: "Water:caustics,Water:caustics" }, /listed twice/],
        [{ frames: "10-1" }, /frames '10-1': END must not be before START/],
        [{ frames: "" }, /frames '': must be one range START-END/],
        [{ frames: "1-5,8" }, /frames '1-5,8': must be one range/],
        [{ frames: "-3" }, /must be one range/],
        [{ frames: "a-b" }, /must be one range/],
        [{ chunk_size: 0 }, /chunk_size = 0: must be a whole number >= 1/],
        [{ chunk_size: 1.5 }, /chunk_size/],
        [{ threads: -1 }, /threads = -1/],
        [{ blendfile: "" }, /blendfile: required/],
        [{ cache_root: " " }, /cache_root: required/],
        [{ render_output_root: undefined }, /render_output_root: required/],
    ];
    for (const [overrides, message] of bad) {
        assert.throws(() => compile(overrides), (err) => {
            assert.match(String(err.message), /^hydrobake: /);
            assert.match(String(err.message), message);
            return true;
        }, JSON.stringify(overrides));
    }
});
