// Shared by the replay viewer and the play page (inlined by rllib_pommer/viz/page.py): the board
// is blitted from the tile sheet, one encoded string per board (see page.py), and the agents'
// table is filled from [alive, ammo, blast, kick] rows (and in TeamRadio each agent's words).
"use strict";

function pommerBoard(canvas, assets) {
  const { size, cell, tiles, tileChars } = assets;
  const ctx = canvas.getContext("2d");
  canvas.width = canvas.height = size * cell;
  ctx.imageSmoothingEnabled = false;
  const sheet = new Image();
  const loaded = new Promise((resolve) => { sheet.onload = resolve; });
  sheet.src = assets.sheet;
  let drawn = [];
  return {
    loaded,
    // Draw one board; returns the tile names drawn per cell, bottom layer first.
    draw(encoded) {
      drawn = encoded.split(".").map((stack) => [...stack].map((ch) => tiles[tileChars.indexOf(ch)]));
      ctx.clearRect(0, 0, canvas.width, canvas.height);
      drawn.forEach((stack, k) => {
        const x = (k % size) * cell, y = Math.floor(k / size) * cell;
        for (const name of stack) {
          ctx.drawImage(sheet, tiles.indexOf(name) * cell, 0, cell, cell, x, y, cell, cell);
        }
      });
      return drawn;
    },
    drawn: () => drawn,
    pixel: (x, y) => Array.from(ctx.getImageData(x, y, 1, 1).data),
  };
}

// One row per agent: id with its team colour, then `players[id]` if given, state, ammo, blast,
// kick, the action it last played and, if `words` is given (TeamRadio), the words it last sent.
function fillAgentTable(tbody, assets, agents, actions, players, words) {
  tbody.innerHTML = "";
  agents.forEach(([alive, ammo, blast, kick], id) => {
    const row = document.createElement("tr");
    if (!alive) row.className = "dead";
    const first = document.createElement("td");
    const dot = document.createElement("span");
    dot.className = "dot";
    dot.style.background = assets.teamColours[id % 2];
    first.append(dot, String(id));
    row.append(first);
    for (const text of [...(players ? [players[id]] : []), alive ? "alive" : "dead", ammo, blast,
                        kick ? "yes" : "", actions ? actions[id] : "",
                        ...(words ? [words[id].join(" ")] : [])]) {
      const cell = document.createElement("td");
      cell.textContent = text;
      row.append(cell);
    }
    tbody.append(row);
  });
}
