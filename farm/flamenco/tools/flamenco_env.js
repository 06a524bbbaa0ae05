// Runs a Flamenco 3.x job compiler script in Node, with stand-ins for the globals Flamenco
// Manager gives such scripts (internal/manager/job_compilers in Flamenco's source): `author`,
// `path`, `print`, `alert`, `frameChunker`, `frameCount`, `formatTimestampLocal`. Anything else
// (require, console, process, ...) is absent, so a script using it fails here as on the Manager.
"use strict";
const fs = require("node:fs");
const posix = require("node:path").posix;
const vm = require("node:vm");

let lastUUID = 0;

// author.Task(name, type): a task with a UUID and default priority 50; name and type are
// trimmed and required.
function Task(name, type) {
    name = String(name).trim();
    type = String(type).trim();
    if (!name) throw new Error("author.Task(name, type): name is required");
    if (!type) throw new Error("author.Task(name, type): type is required");
    const task = {
        uuid: `task-${++lastUUID}`, name, type, priority: 50, commands: [], dependencies: [],
        addCommand(cmd) { task.commands.push(cmd); },
        addDependency(dep) { task.dependencies.push(dep); },
    };
    return task;
}

// author.Command(name, parameters[, totalStepCount]): a command for the Worker.
function Command(name, parameters, totalStepCount) {
    return { name, parameters, totalStepCount: totalStepCount || 0 };
}

// Flamenco's frame range helpers accept "1-10,20..25,40", and return chunks in "-" notation,
// two consecutive frames as "9,10".
function explode(range) {
    const frames = new Set();
    for (const part of range.replaceAll("..", "-").split(",")) {
        const ends = part.split("-");
        const nums = ends.map((s) => (/^\s*\d+\s*$/.test(s) ? Number(s) : NaN));
        if (ends.length > 2 || nums.some(Number.isNaN)) {
            throw new Error(`invalid range "${range}": ${part}`);
        }
        const [a, b = a] = nums;
        for (let f = a; f <= b; f++) frames.add(f);
    }
    if (!frames.size) throw new Error(`invalid range "${range}": empty range`);
    return [...frames].sort((x, y) => x - y);
}

function merge(frames) {
    const out = [];
    let start = frames[0];
    for (let i = 1; i <= frames.length; i++) {
        if (i < frames.length && frames[i] === frames[i - 1] + 1) continue;
        const end = frames[i - 1];
        if (start === end) out.push(`${start}`);
        else if (start + 1 === end) out.push(`${start}`, `${end}`);
        else out.push(`${start}-${end}`);
        start = frames[i];
    }
    return out.join(",");
}

function frameChunker(range, chunkSize) {
    range = String(range).trim();
    if (!range) throw new Error(`invalid range "${range}": empty range`);
    if (!(chunkSize >= 1)) throw new Error(`invalid chunk size, must be positive number: ${chunkSize}`);
    const frames = explode(range);
    const chunks = [];
    for (let i = 0; i < frames.length; i += chunkSize) chunks.push(merge(frames.slice(i, i + chunkSize)));
    return chunks;
}

function formatTimestampLocal(date) {
    const p = (n) => String(n).padStart(2, "0");
    return `${date.getFullYear()}-${p(date.getMonth() + 1)}-${p(date.getDate())}_`
        + `${p(date.getHours())}${p(date.getMinutes())}${p(date.getSeconds())}`;
}

// The `path` module: forward-slash paths, backslashes taken as separators too.
const slash = (p) => String(p).replaceAll("\\", "/");
const path = {
    basename: (p) => posix.basename(slash(p)) || (slash(p).startsWith("/") ? "/" : "."),
    dirname: (p) => {
        const s = slash(p);
        const i = s.lastIndexOf("/");
        return i < 0 ? "." : i === 0 ? "/" : s.slice(0, i);
    },
    join: (...parts) => {
        const nonEmpty = parts.filter((x) => x !== "");
        if (!nonEmpty.length) return "";
        const joined = posix.normalize(nonEmpty.join("/"));
        return slash(joined.length > 1 ? joined.replace(/\/$/, "") : joined);
    },
    stem: (p) => {
        const base = path.basename(p);
        return base.slice(0, base.length - posix.extname(base).length);
    },
};

// Loads a job compiler script; returns {JOB_TYPE, compile(settings, options), log}.
// compile() builds a job like the Manager does and runs compileJob() on it. As on the Manager,
// job.addTask() stores a copy of the task as it is then: later changes to it are not kept.
// The returned job.tasks hold plain data: commands, and dependencies as {uuid, name}.
function load(file) {
    const log = [];
    const globals = {
        author: { Task, Command },
        path,
        print: (...args) => log.push(args.map(String).join(" ")),
        alert: (...args) => log.push("ALERT " + args.map(String).join(" ")),
        frameChunker,
        frameCount: (range) => explode(String(range)).length,
        formatTimestampLocal,
    };
    const context = vm.createContext(globals);
    // Flamenco compiles the scripts in strict mode.
    const source = '"use strict"; ' + fs.readFileSync(file, "utf8") + "\n;({ JOB_TYPE, compileJob });";
    const { JOB_TYPE, compileJob } = vm.runInContext(source, context, { filename: file });

    function compile(settings, options = {}) {
        const tasks = [];
        const job = {
            name: options.name || "job",
            type: "hydrobake",
            priority: 50,
            created: options.created || new Date(),
            settings: { ...settings },
            metadata: { ...(options.metadata || {}) },
            tasks,
            // Commands go through JSON as they do on the way to the database and the Workers.
            addTask(task) {
                tasks.push({
                    uuid: task.uuid, name: task.name, type: task.type, priority: task.priority,
                    commands: JSON.parse(JSON.stringify(task.commands)),
                    dependencies: task.dependencies.map((d) => ({ uuid: d.uuid, name: d.name })),
                });
            },
        };
        compileJob(job);
        return job;
    }
    return { JOB_TYPE, compile, log };
}

// Text listing of a compiled job's tasks, their dependencies and commands.
function describe(job) {
    const lines = [];
    for (const t of job.tasks) {
        const deps = t.dependencies.map((d) => d.name);
        lines.push(`${t.name}  [type ${t.type}]` + (deps.length ? `  after: ${deps.join(", ")}` : ""));
        for (const c of t.commands) {
            const p = c.parameters;
            const args = (p.args || []).map((a) => (a.includes("\n") ? `<python, ${a.split("\n").length} lines>`
                : /[\s"']/.test(a) || a === "" ? JSON.stringify(a) : a));
            const words = [p.exe, p.exeArgs, ...(p.argsBefore || []), p.blendfile, ...args];
            lines.push(`    ${c.name}: ${words.filter((w) => w).join(" ")}`);
        }
    }
    return lines.join("\n");
}

module.exports = { load, describe, frameChunker, path, formatTimestampLocal };
