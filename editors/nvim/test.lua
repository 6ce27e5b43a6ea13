-- Neovim's built-in LSP client against `shadec lsp` (issue 21): opens a
-- file, waits for its diagnostics, fixes the error by editing the buffer,
-- hovers, renames with `vim.lsp.buf.rename` (prepareRename first) and checks
-- the result. Written for Neovim 0.7 (Debian 12's), so it uses
-- `vim.lsp.start_client` + `vim.lsp.buf_attach_client`.
--
-- Run by tests/editor_nvim.rs:
--   SHADEC_BIN=… SHADEC_TEST_FILE=….shd nvim --headless --clean -c 'luafile editors/nvim/test.lua'
-- Exit status 0 when every check passed; each failure is printed to stderr.

local bin = assert(os.getenv('SHADEC_BIN'), 'set SHADEC_BIN')
local file = assert(os.getenv('SHADEC_TEST_FILE'), 'set SHADEC_TEST_FILE')
local failures = {}

local function check(ok, what)
  if not ok then
    table.insert(failures, what)
  end
  return ok
end

local function finish()
  for _, f in ipairs(failures) do
    io.stderr:write('FAIL: ' .. f .. '\n')
  end
  io.stderr:write(string.format('%d failure(s)\n', #failures))
  vim.cmd('cquit ' .. (#failures == 0 and 0 or 1))
end

local function buffer_text(buf)
  return table.concat(vim.api.nvim_buf_get_lines(buf, 0, -1, false), '\n')
end

-- 0-based line and byte column of the first `needle` in the buffer.
local function find(buf, needle)
  for i, line in ipairs(vim.api.nvim_buf_get_lines(buf, 0, -1, false)) do
    local col = line:find(needle, 1, true)
    if col then
      return i - 1, col - 1
    end
  end
  error('not in the buffer: ' .. needle)
end

local ok_all, err = pcall(function()
  vim.cmd('edit ' .. vim.fn.fnameescape(file))
  local buf = vim.api.nvim_get_current_buf()
  local id = vim.lsp.start_client({
    name = 'shadec',
    cmd = { bin, 'lsp' },
    root_dir = vim.fn.fnamemodify(file, ':h'),
    init_options = { shadec = { target = 'geforce3' } },
  })
  check(id ~= nil, 'the client started')
  vim.lsp.buf_attach_client(buf, id)
  local client = vim.lsp.get_client_by_id(id)

  -- 1. Diagnostics on open: the typo, located, with its "did you mean".
  local got = vim.wait(20000, function() return #vim.diagnostic.get(buf) > 0 end, 20)
  check(got, 'diagnostics arrived after opening')
  local errors = vim.diagnostic.get(buf, { severity = vim.diagnostic.severity.ERROR })
  local d = errors[1]
  local line, col = find(buf, 'Ligth')
  check(d ~= nil and d.message == 'unknown name `Ligth`\nhelp: did you mean `Light`?', 'the typo error: ' .. vim.inspect(d))
  check(d ~= nil and d.lnum == line and d.col == col, 'the typo is located: ' .. vim.inspect(d))

  -- 2. Fix it in the buffer (Neovim sends didChange); the errors go.
  vim.api.nvim_buf_set_text(buf, line, col, line, col + #'Ligth', { 'Light' })
  got = vim.wait(20000, function()
    return #vim.diagnostic.get(buf, { severity = vim.diagnostic.severity.ERROR }) == 0
  end, 20)
  check(got, 'the error cleared after the fix: ' .. vim.inspect(vim.diagnostic.get(buf)))

  -- 3. Hover on the texture lookup: type, frequency, texture unit on geforce3.
  line, col = find(buf, 'T δu x;')
  local params = { textDocument = vim.lsp.util.make_text_document_params(buf), position = { line = line, character = col } }
  local res = client.request_sync('textDocument/hover', params, 10000, buf)
  local value = res and res.result and res.result.contents and res.result.contents.value or ''
  check(value:find('- frequency: per-fragment', 1, true) ~= nil, 'hover says per-fragment: ' .. value)
  check(value:find('- geforce3, pass 1: texture unit 0 (`T`)', 1, true) ~= nil, 'hover says where it lands: ' .. value)

  -- 4. Inlay hints (Neovim 0.7 has no inlay-hint display: asked directly).
  local range = { start = { line = 0, character = 0 }, ['end'] = { line = vim.api.nvim_buf_line_count(buf), character = 0 } }
  res = client.request_sync('textDocument/inlayHint', { textDocument = params.textDocument, range = range }, 10000, buf)
  local labels = {}
  for _, h in ipairs(res and res.result or {}) do
    table.insert(labels, h.label)
  end
  check(vim.tbl_contains(labels, 'pass 1 (geforce3)'), 'the statement\'s inlay hint: ' .. vim.inspect(labels))

  -- 5. Rename `base` everywhere with the editor's own command.
  line, col = find(buf, 'base')
  vim.api.nvim_win_set_cursor(0, { line + 1, col })
  vim.lsp.buf.rename('albedo')
  got = vim.wait(10000, function() return not buffer_text(buf):find('base', 1, true) end, 20)
  check(got, 'every `base` was renamed: ' .. buffer_text(buf))
  local _, n = buffer_text(buf):gsub('albedo', '')
  check(n == 2, 'two occurrences renamed, got ' .. n)
  got = vim.wait(20000, function()
    local all = vim.diagnostic.get(buf)
    return #all == 0
  end, 20)
  check(got, 'the renamed program is clean: ' .. vim.inspect(vim.diagnostic.get(buf)))

  vim.lsp.stop_client(id)
end)
check(ok_all, 'the script ran: ' .. tostring(err))
finish()
