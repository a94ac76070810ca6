// <dynview-viewer>: the viewer in a page of your own, with one tag.
//
//   <script type="module" src="https://your.host/dynview/src/embed.js"></script>
//   <dynview-viewer src="scenes/concert/" style="width: 100%; max-width: 960px"></dynview-viewer>
//
// The element holds the viewer page (index.html, next to this file's folder) in an iframe in
// embed mode: the view and the timeline, without the app's bars. `src` is the scene package
// folder, relative to the embedding page; `renderer` (cpu or gpu) forces a renderer. No
// cross-origin-isolation headers are needed. Across origins, the viewer's host must let the
// embedding page load this module (CORS) and the scene must be readable by the viewer's page.

/** The viewer page, wherever this module is served from. */
const VIEWER_PAGE = new URL("../index.html", import.meta.url);

/**
 * The viewer page's URL for a scene folder `src` (resolved against `base`, the embedding
 * page) and an optional forced renderer.
 * @param {string | null} src
 * @param {string} base
 * @param {string | null} [renderer]
 */
export function viewerUrl(src, base, renderer = null) {
  const url = new URL(VIEWER_PAGE);
  url.searchParams.set("embed", "1");
  if (src) url.searchParams.set("scene", new URL(src, base).href);
  if (renderer) url.searchParams.set("renderer", renderer);
  return url.href;
}

const STYLE = `
  :host { display: block; aspect-ratio: 16 / 11; min-height: 200px; background: #111418; }
  iframe { display: block; width: 100%; height: 100%; border: 0; }
`;

/** `<dynview-viewer src="scene/" renderer="cpu|gpu">`. */
export class DynviewViewer extends HTMLElement {
  static observedAttributes = ["src", "renderer"];

  constructor() {
    super();
    const root = this.attachShadow({ mode: "open" });
    const style = document.createElement("style");
    style.textContent = STYLE;
    this.frame = document.createElement("iframe");
    this.frame.title = "dynview viewer";
    this.frame.allow = "fullscreen";
    root.append(style, this.frame);
  }

  connectedCallback() {
    this.load();
  }

  attributeChangedCallback() {
    if (this.isConnected) this.load();
  }

  load() {
    const url = viewerUrl(this.getAttribute("src"), document.baseURI, this.getAttribute("renderer"));
    if (this.frame.src !== url) this.frame.src = url;
  }
}

if (!customElements.get("dynview-viewer")) customElements.define("dynview-viewer", DynviewViewer);
