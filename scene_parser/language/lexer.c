/* vbnl scene parser: the raw tokenizer (comments, numbers, strings, identifiers, operators). */
#include <ctype.h>
#include <stdlib.h>
#include <string.h>

#include "sdl_internal.h"

static const vbnl_sdl_token eof_token = { VBNL_SDL_TOK_EOF, 0, 0, "", 0, 0.0, { "", 0, 0 } };

void sdl_token_free(vbnl_sdl_token *tok)
{
    if (tok->kind == VBNL_SDL_TOK_STRING)
        free((char *)tok->text);
    *tok = eof_token;
}

const char *sdl_token_describe(const vbnl_sdl_token *tok, char *buf, size_t n)
{
    switch (tok->kind) {
    case VBNL_SDL_TOK_EOF: snprintf(buf, n, "end of file"); break;
    case VBNL_SDL_TOK_NUMBER: snprintf(buf, n, "'%.*s'", (int)(tok->len > 40 ? 40 : tok->len), tok->text); break;
    case VBNL_SDL_TOK_STRING: snprintf(buf, n, "string \"%.*s%s\"", (int)(tok->len > 30 ? 30 : tok->len), tok->text, tok->len > 30 ? "..." : ""); break;
    default: snprintf(buf, n, "'%.*s'", (int)(tok->len > 60 ? 60 : tok->len), tok->text); break;
    }
    return buf;
}

static void advance(sdl_frame *f, size_t n)
{
    const char *s = f->file->text;
    for (size_t i = 0; i < n && f->pos.off < f->file->len; i++) {
        if (s[f->pos.off] == '\n') {
            f->pos.line++;
            f->pos.col = 1;
        } else {
            f->pos.col++;
        }
        f->pos.off++;
    }
}

/* Skips whitespace and comments; false after reporting an unterminated comment. */
static bool skip_space(vbnl_sdl_parser *p, sdl_frame *f)
{
    const char *s = f->file->text;
    size_t len = f->file->len;
    for (;;) {
        size_t o = f->pos.off;
        if (o >= len)
            return true;
        char c = s[o];
        if (c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v' || c == 26) {
            advance(f, 1);
        } else if (c == '/' && o + 1 < len && s[o + 1] == '/') {
            while (f->pos.off < len && s[f->pos.off] != '\n')
                advance(f, 1);
        } else if (c == '/' && o + 1 < len && s[o + 1] == '*') {
            vbnl_sdl_loc start = { f->file->name, f->pos.line, f->pos.col };
            int depth = 0;
            /* POV-Ray nests block comments. */
            for (;;) {
                if (f->pos.off >= len) {
                    sdl_errorf(p, &start, "unterminated comment (missing '*/')");
                    return false;
                }
                o = f->pos.off;
                if (s[o] == '/' && o + 1 < len && s[o + 1] == '*') {
                    depth++;
                    advance(f, 2);
                } else if (s[o] == '*' && o + 1 < len && s[o + 1] == '/') {
                    advance(f, 2);
                    if (--depth == 0)
                        break;
                } else {
                    advance(f, 1);
                }
            }
        } else if ((unsigned char)c == 0xEF && o + 2 < len && (unsigned char)s[o + 1] == 0xBB &&
                   (unsigned char)s[o + 2] == 0xBF) {
            advance(f, 3); /* UTF-8 byte order mark */
        } else {
            return true;
        }
    }
}

static int hexval(char c)
{
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

static void lex_string(vbnl_sdl_parser *p, sdl_frame *f, vbnl_sdl_token *tok)
{
    const char *s = f->file->text;
    size_t len = f->file->len;
    size_t cap = 32, n = 0;
    char *out = malloc(cap);
    if (!out) {
        sdl_errorf(p, &tok->loc, "out of memory");
        return;
    }
    advance(f, 1);
    for (;;) {
        if (f->pos.off >= len) {
            free(out);
            sdl_errorf(p, &tok->loc, "unterminated string (missing closing '\"')");
            return;
        }
        char c = s[f->pos.off];
        char e[4];
        size_t ne = 1;
        e[0] = c;
        if (c == '"') {
            advance(f, 1);
            break;
        }
        if (c == '\\' && f->pos.off + 1 < len) {
            char d = s[f->pos.off + 1];
            vbnl_sdl_loc el = { f->file->name, f->pos.line, f->pos.col };
            advance(f, 2);
            switch (d) {
            case 'n': e[0] = '\n'; break;
            case 't': e[0] = '\t'; break;
            case 'r': e[0] = '\r'; break;
            case 'a': e[0] = '\a'; break;
            case 'b': e[0] = '\b'; break;
            case 'f': e[0] = '\f'; break;
            case 'v': e[0] = '\v'; break;
            case '\\': e[0] = '\\'; break;
            case '"': e[0] = '"'; break;
            case '\'': e[0] = '\''; break;
            case 'u': {
                unsigned cp = 0;
                int k;
                for (k = 0; k < 4 && f->pos.off < len && hexval(s[f->pos.off]) >= 0; k++) {
                    cp = cp * 16 + (unsigned)hexval(s[f->pos.off]);
                    advance(f, 1);
                }
                if (k != 4) {
                    free(out);
                    sdl_errorf(p, &el, "\\u escape needs four hexadecimal digits");
                    return;
                }
                if (cp < 0x80) {
                    e[0] = (char)cp;
                } else if (cp < 0x800) {
                    e[0] = (char)(0xC0 | (cp >> 6)); e[1] = (char)(0x80 | (cp & 63)); ne = 2;
                } else {
                    e[0] = (char)(0xE0 | (cp >> 12)); e[1] = (char)(0x80 | ((cp >> 6) & 63));
                    e[2] = (char)(0x80 | (cp & 63)); ne = 3;
                }
                break;
            }
            default:
                /* POV-Ray keeps unknown escapes (Windows paths) with a warning. */
                sdl_warnf(p, &el, "unknown escape sequence '\\%c' kept as is", d);
                e[0] = '\\'; e[1] = d; ne = 2;
                break;
            }
        } else {
            advance(f, 1);
        }
        if (n + ne + 1 > cap) {
            cap = cap * 2 + ne;
            char *q = realloc(out, cap);
            if (!q) {
                free(out);
                sdl_errorf(p, &tok->loc, "out of memory");
                return;
            }
            out = q;
        }
        memcpy(out + n, e, ne);
        n += ne;
    }
    out[n] = 0;
    tok->kind = VBNL_SDL_TOK_STRING;
    tok->text = out;
    tok->len = n;
}

void sdl_lex(vbnl_sdl_parser *p, sdl_frame *f, vbnl_sdl_token *tok)
{
    *tok = eof_token;
    if (p->failed || !skip_space(p, f))
        return;
    const char *s = f->file->text;
    size_t len = f->file->len, o = f->pos.off;
    tok->loc.file = f->file->name;
    tok->loc.line = f->pos.line;
    tok->loc.col = f->pos.col;
    if (o >= len)
        return;
    if (++p->tokens > p->limits.max_tokens) {
        sdl_errorf(p, &tok->loc, "token limit exceeded (%llu tokens)",
                   (unsigned long long)p->limits.max_tokens);
        return;
    }
    unsigned char c = (unsigned char)s[o];
    if (isalpha(c) || c == '_') {
        size_t e = o;
        while (e < len && (isalnum((unsigned char)s[e]) || s[e] == '_'))
            e++;
        int kw = 0;
        const char *name = sdl_intern(p, s + o, e - o, &kw);
        if (!name)
            return;
        tok->kind = VBNL_SDL_TOK_IDENT;
        tok->text = name;
        tok->len = e - o;
        tok->keyword = kw;
        advance(f, e - o);
        return;
    }
    if (isdigit(c) || (c == '.' && o + 1 < len && isdigit((unsigned char)s[o + 1]))) {
        size_t e = o;
        while (e < len && isdigit((unsigned char)s[e]))
            e++;
        if (e < len && s[e] == '.') {
            e++;
            while (e < len && isdigit((unsigned char)s[e]))
                e++;
        }
        if (e < len && (s[e] == 'e' || s[e] == 'E')) {
            size_t k = e + 1;
            if (k < len && (s[k] == '+' || s[k] == '-'))
                k++;
            if (k < len && isdigit((unsigned char)s[k])) {
                while (k < len && isdigit((unsigned char)s[k]))
                    k++;
                e = k;
            }
        }
        char buf[64];
        size_t n = e - o < sizeof buf - 1 ? e - o : sizeof buf - 1;
        memcpy(buf, s + o, n);
        buf[n] = 0;
        tok->kind = VBNL_SDL_TOK_NUMBER;
        tok->number = strtod(buf, NULL);
        tok->text = s + o; /* not NUL-terminated at len: use len */
        tok->len = e - o;
        advance(f, e - o);
        return;
    }
    if (c == '"') {
        lex_string(p, f, tok);
        return;
    }
    static const struct { const char *s; int op; } two[] = {
        { "<=", VBNL_SDL_OP_LE }, { ">=", VBNL_SDL_OP_GE }, { "!=", VBNL_SDL_OP_NE }, { "==", VBNL_SDL_OP_EQ2 },
    };
    for (size_t i = 0; i < sizeof two / sizeof two[0]; i++) {
        if (o + 1 < len && s[o] == two[i].s[0] && s[o + 1] == two[i].s[1]) {
            tok->kind = VBNL_SDL_TOK_PUNCT;
            tok->op = two[i].op;
            tok->text = two[i].s;
            tok->len = 2;
            advance(f, 2);
            return;
        }
    }
    static const char singles[] = "{}()[]<>=!,;.+-*/?:&|#%^'@$\\~`";
    const char *q = c ? strchr(singles, c) : NULL;
    if (q && strchr("%^'@$\\~`", c) == NULL) {
        static const char spell[] = "{\0}\0(\0)\0[\0]\0<\0>\0=\0!\0,\0;\0.\0+\0-\0*\0/\0?\0:\0&\0|\0#";
        tok->kind = VBNL_SDL_TOK_PUNCT;
        tok->op = c;
        tok->text = spell + 2 * (q - singles);
        tok->len = 1;
        advance(f, 1);
        return;
    }
    if (c >= 32 && c < 127)
        sdl_errorf(p, &tok->loc, "unexpected character '%c'", c);
    else
        sdl_errorf(p, &tok->loc, "unexpected byte 0x%02X (SDL text is ASCII outside strings)", c);
}
