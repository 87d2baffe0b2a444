#!/usr/bin/env node
// The Khronos glTF validator (npm package gltf-validator, installed by scripts/_setup.sh into
// .tools/node) over each file named: prints one JSON array of reports, one per file, each
// {file, errors, warnings, infos, hints, messages: [{code, message, severity, pointer}]}.
// Exit 0 when every file was read; the caller judges the counts.
"use strict";
const fs = require("fs");
const path = require("path");
const validator = require(path.join(__dirname, "..", ".tools", "node", "node_modules", "gltf-validator"));

async function main(files) {
    const reports = [];
    for (const file of files) {
        const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(file)), {
            uri: path.basename(file),
            maxIssues: 0,
            writeTimestamp: false,
        });
        reports.push({
            file,
            validator: report.validatorVersion,
            errors: report.issues.numErrors,
            warnings: report.issues.numWarnings,
            infos: report.issues.numInfos,
            hints: report.issues.numHints,
            messages: report.issues.messages,
            info: report.info,
        });
    }
    process.stdout.write(JSON.stringify(reports, null, 1) + "\n");
}

main(process.argv.slice(2)).catch((error) => {
    console.error(`gltf-validate: ${error}`);
    process.exit(1);
});
