/* The line rate of a terminal (TCGETS2 c_ospeed, bit/s; 0 on error): apart from the probe because
 * <asm/termbits.h> and <termios.h> cannot meet in one file. */
#pragma once
unsigned line_rate(int fd);
