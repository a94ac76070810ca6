// Collecting a dropped or picked scene folder as (File, relative path) pairs.

/** Reads every file under a FileSystemEntry (drag and drop), with its path. */
async function collectEntry(entry, out) {
  if (entry.isFile) {
    const file = await new Promise((resolve, reject) => entry.file(resolve, reject));
    out.push({ file, path: entry.fullPath.replace(/^\//, "") });
  } else if (entry.isDirectory) {
    const reader = entry.createReader();
    for (;;) {
      const batch = await new Promise((resolve, reject) => reader.readEntries(resolve, reject));
      if (batch.length === 0) break;
      for (const child of batch) await collectEntry(child, out);
    }
  }
}

/** The files of a drop event (folders are walked). */
export async function filesFromDrop(dataTransfer) {
  const entries = [...dataTransfer.items].map((item) => item.webkitGetAsEntry?.()).filter(Boolean);
  const out = [];
  if (entries.length) {
    for (const entry of entries) await collectEntry(entry, out);
  } else {
    for (const file of dataTransfer.files) out.push({ file, path: file.name });
  }
  return out;
}

/** The files of an `<input type=file webkitdirectory>`. */
export function filesFromInput(input) {
  return [...input.files].map((file) => ({ file, path: file.webkitRelativePath || file.name }));
}
