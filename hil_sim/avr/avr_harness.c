/*
 * avr_harness.c - runs a firmware ELF for the Arduino Nano (ATmega328P, 16 MHz) in libsimavr and
 * lets a controlling program drive it over stdin/stdout, one command per line:
 *
 *   send HEX          queue bytes (hex) for UART0; they enter as fast as the UART takes them
 *   run US            run US emulated microseconds, then print what happened, then "T <cycle>"
 *   rc PIN WIDTH_US   50 Hz pulses of WIDTH_US on input pin D<PIN> (3 or 4); 0 stops them
 *   eeprom HEX        write bytes (hex) into the EEPROM from address 0 (before a run: as flashed)
 *   eeprom?           print "E <hex>": the first 64 bytes of the EEPROM
 *   reset             reset the chip (as its reset pin or a power cycle: the EEPROM stays)
 *   quit
 *
 * Output lines (cycles count from reset; 16 cycles per microsecond):
 *   P <pin> <rise_cycle> <width_cycles>   a complete high pulse on D5, D6 or B5
 *   U <cycle> <text>                      a line the firmware printed on UART0
 *   S <cycle>                             the last queued byte entered the UART
 *   T <cycle>                             end of a run
 *
 * With --pty SECONDS the harness instead bridges UART0 to a pseudo-terminal (simavr's uart_pty),
 * paces emulation to the wall clock, prints "PTY /dev/pts/N" and then streams P/U lines until
 * SECONDS have been emulated. Exit status 2 on bad usage, 1 if the CPU crashed.
 */
#define _GNU_SOURCE
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "avr_eeprom.h"
#include "avr_ioport.h"
#include "avr_uart.h"
#include "sim_avr.h"
#include "sim_elf.h"
#include "sim_io.h"
#include "sim_irq.h"
#include "sim_time.h"
#include "uart_pty.h"

#define F_CPU 16000000UL
#define CYCLES_PER_US (F_CPU / 1000000UL)
#define FRAME_US 20000u

static avr_t *avr;

/* ---- output pulses: D5 (ESC), D6 (steering), B5 (benchmark marker) ---- */
typedef struct { char port; int bit; int level; uint64_t rise; } watched_pin_t;
static watched_pin_t watched[] = { {'D', 5, 0, 0}, {'D', 6, 0, 0}, {'B', 5, 0, 0} };

static void pin_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq;
	watched_pin_t *p = param;
	int level = value ? 1 : 0;
	if (level == p->level) return; /* simavr raises every output pin's IRQ on each PORT write */
	p->level = level;
	if (level) { p->rise = avr->cycle; return; }
	if (p->rise) printf("P %c%d %llu %llu\n", p->port, p->bit, (unsigned long long)p->rise,
	                    (unsigned long long)(avr->cycle - p->rise));
}

/* ---- UART0 ---- */
static char line[256];
static int line_len;
static void uart_out_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq; (void)param;
	char c = (char)value;
	if (c == '\r') return;
	if (c == '\n' || line_len == (int)sizeof(line) - 1) {
		line[line_len] = 0;
		printf("U %llu %s\n", (unsigned long long)avr->cycle, line);
		line_len = 0;
		return;
	}
	line[line_len++] = c;
}

static uint8_t txq[8192];
static int txq_head, txq_tail, uart_xoff, tx_pending_mark;
static avr_irq_t *uart_in_irq;

static void uart_pump(void)
{
	while (!uart_xoff && txq_head != txq_tail) {
		uint8_t b = txq[txq_tail];
		txq_tail = (txq_tail + 1) % (int)sizeof(txq);
		avr_raise_irq(uart_in_irq, b);
	}
	if (tx_pending_mark && txq_head == txq_tail) {
		printf("S %llu\n", (unsigned long long)avr->cycle);
		tx_pending_mark = 0;
	}
}
static void uart_xon_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq; (void)value; (void)param;
	uart_xoff = 0;
	uart_pump();
}
static void uart_xoff_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq; (void)param;
	uart_xoff = (int)value;
}

/* ---- RC receiver pulses into D3/D4 ---- */
typedef struct { int pin; uint32_t width_us; int high; } rc_t;
static rc_t rc[2] = { {3, 0, 0}, {4, 0, 0} };

static avr_cycle_count_t rc_edge(avr_t *a, avr_cycle_count_t when, void *param)
{
	rc_t *r = param;
	avr_irq_t *pin = avr_io_getirq(a, AVR_IOCTL_IOPORT_GETIRQ('D'), r->pin);
	if (r->width_us == 0) { /* switched off: end low */
		if (r->high) avr_raise_irq(pin, 0);
		r->high = 0;
		return 0;
	}
	r->high = !r->high;
	avr_raise_irq(pin, r->high);
	return when + (r->high ? r->width_us : FRAME_US - r->width_us) * CYCLES_PER_US;
}

static void no_sleep(avr_t *a, avr_cycle_count_t how_long) { (void)a; (void)how_long; }

static double wall_s(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return ts.tv_sec + ts.tv_nsec * 1e-9;
}

static int run_cycles(uint64_t until, int realtime, double t0)
{
	uint64_t next_pace = 0;
	while (avr->cycle < until) {
		int state = avr_run(avr);
		if (state == cpu_Done || state == cpu_Crashed) return state;
		if (realtime && avr->cycle >= next_pace) {
			next_pace = avr->cycle + F_CPU / 1000;
			double ahead = avr->cycle / (double)F_CPU - (wall_s() - t0);
			if (ahead > 0.0005) usleep((useconds_t)(ahead * 1e6));
		}
	}
	return cpu_Running;
}

int main(int argc, char **argv)
{
	const char *fw = NULL;
	double pty_seconds = 0;
	for (int i = 1; i < argc; i++) {
		if (!strcmp(argv[i], "--pty") && i + 1 < argc) pty_seconds = atof(argv[++i]);
		else if (argv[i][0] != '-' && !fw) fw = argv[i];
		else { fprintf(stderr, "usage: %s FIRMWARE.elf [--pty SECONDS]\n", argv[0]); return 2; }
	}
	if (!fw) { fprintf(stderr, "usage: %s FIRMWARE.elf [--pty SECONDS]\n", argv[0]); return 2; }

	elf_firmware_t f;
	memset(&f, 0, sizeof f);
	if (elf_read_firmware(fw, &f)) { fprintf(stderr, "cannot read %s\n", fw); return 2; }
	if (!f.mmcu[0]) strcpy(f.mmcu, "atmega328p"); /* Arduino ELFs carry no .mmcu section */
	if (!f.frequency) f.frequency = F_CPU;
	avr = avr_make_mcu_by_name(f.mmcu);
	if (!avr) { fprintf(stderr, "unknown mcu %s\n", f.mmcu); return 2; }
	avr_init(avr);
	avr_load_firmware(avr, &f);
	avr->sleep = no_sleep;
	avr->log = LOG_WARNING;

	uint32_t flags = 0; /* no usleep on UART polls, no echo to our stdout */
	avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
	avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT), uart_out_hook, NULL);
	for (unsigned i = 0; i < sizeof watched / sizeof watched[0]; i++)
		avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(watched[i].port), watched[i].bit),
		                        pin_hook, &watched[i]);

	if (pty_seconds > 0) {
		static uart_pty_t pty;
		setvbuf(stdout, NULL, _IOLBF, 0);
		uart_pty_init(avr, &pty);
		uart_pty_connect(&pty, '0');
		printf("PTY %s\n", pty.port[0].slavename);
		int state = run_cycles((uint64_t)(pty_seconds * F_CPU), 1, wall_s());
		/* uart_pty_stop() would pthread_kill the bridge thread with SIGINT: just exit. */
		printf("T %llu\n", (unsigned long long)avr->cycle);
		fflush(stdout);
		_exit(state == cpu_Crashed ? 1 : 0);
	}

	uart_in_irq = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
	avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON), uart_xon_hook, NULL);
	avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF), uart_xoff_hook, NULL);

	char cmd[16384];
	while (fgets(cmd, sizeof cmd, stdin)) {
		if (!strncmp(cmd, "send ", 5)) {
			for (char *h = cmd + 5; h[0] && h[1] && h[0] != '\n'; h += 2) {
				unsigned byte;
				if (sscanf(h, "%2x", &byte) != 1) break;
				txq[txq_head] = (uint8_t)byte;
				txq_head = (txq_head + 1) % (int)sizeof(txq);
			}
			tx_pending_mark = 1;
			uart_pump();
		} else if (!strncmp(cmd, "run ", 4)) {
			uint64_t us = strtoull(cmd + 4, NULL, 10);
			int state = run_cycles(avr->cycle + us * CYCLES_PER_US, 0, 0);
			printf("T %llu\n", (unsigned long long)avr->cycle);
			fflush(stdout);
			if (state == cpu_Crashed) { fprintf(stderr, "cpu crashed\n"); return 1; }
		} else if (!strncmp(cmd, "rc ", 3)) {
			int pin = 0;
			unsigned width = 0;
			if (sscanf(cmd + 3, "%d %u", &pin, &width) != 2 || (pin != 3 && pin != 4)) {
				fprintf(stderr, "bad rc command: %s", cmd);
				return 2;
			}
			rc_t *r = &rc[pin - 3];
			int was_running = r->width_us != 0;
			r->width_us = width;
			if (!was_running && width) avr_cycle_timer_register(avr, 1, rc_edge, r);
		} else if (!strncmp(cmd, "eeprom?", 7)) {
			uint8_t ee[64];
			avr_eeprom_desc_t d = { .ee = ee, .offset = 0, .size = sizeof ee };
			avr_ioctl(avr, AVR_IOCTL_EEPROM_GET, &d);
			printf("E ");
			for (unsigned i = 0; i < sizeof ee; i++) printf("%02x", d.ee[i]);
			printf("\n");
			fflush(stdout);
		} else if (!strncmp(cmd, "eeprom ", 7)) {
			uint8_t ee[1024];
			unsigned n = 0;
			for (char *h = cmd + 7; h[0] && h[1] && h[0] != '\n' && n < sizeof ee; h += 2) {
				unsigned byte;
				if (sscanf(h, "%2x", &byte) != 1) break;
				ee[n++] = (uint8_t)byte;
			}
			avr_eeprom_desc_t d = { .ee = ee, .offset = 0, .size = n };
			avr_ioctl(avr, AVR_IOCTL_EEPROM_SET, &d);
		} else if (!strncmp(cmd, "reset", 5)) {
			avr_reset(avr);
		} else if (!strncmp(cmd, "quit", 4)) {
			break;
		} else {
			fprintf(stderr, "unknown command: %s", cmd);
			return 2;
		}
	}
	return 0;
}
